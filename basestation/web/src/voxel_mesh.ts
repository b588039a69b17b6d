// Meshing of one map column's voxels (a /fleet_map entity) for the 3D view: only the faces between a voxel and
// empty space, and coplanar neighbouring faces of one colour merged into one rectangle (greedy meshing, as in
// block-world renderers: Lysenko, "Meshing in a Minecraft game", 2012). A flat floor of 400 voxels becomes one
// quad instead of 400 boxes; a real scan's rough surfaces keep more, but never more than the visible faces.
// Coarser levels (voxels twice and four times the size) are built for views from far away. No three.js here: plain arrays,
// so that node tests check it. Frame: the map frame, z up, metres.

export type Vec3 = { x: number; y: number; z: number };
export type Rgba = { r: number; g: number; b: number; a: number };
/** One voxel as /fleet_map sends it (a foxglove.CubePrimitive): its centre, edge lengths and colour. */
export interface VoxelCube {
  pose: { position: Vec3 };
  size: Vec3;
  color: Rgba;
}

/** The voxels of a column on their grid: `cells[i + nx * (j + ny * k)]` is 0 (empty) or 1 + a 24-bit colour. */
export interface VoxelGrid {
  res: number; // edge, m
  origin: [number, number, number]; // centre of cell (0, 0, 0), m
  dims: [number, number, number];
  cells: Int32Array;
}

/** Triangles ready for a BufferGeometry: positions relative to `centre` (m), colours (linear, shaded by face
 *  direction), 6 indices per quad. */
export interface VoxelMesh {
  centre: [number, number, number];
  positions: Float32Array;
  colors: Float32Array;
  indices: Uint32Array;
  quads: number;
}

// Cells a column may span before it is drawn box by box instead (a malformed column many metres tall).
const kMaxCells = 4_000_000;

// Shade per face direction (no lighting computed per pixel): tops brightest, x sides, then y sides.
const kShadeTop = 1.0;
const kShadeX = 0.8;
const kShadeY = 0.66;
// How far each rectangle reaches past its voxels' edges, in voxels (covers T-junction cracks).
const kOverlap = 0.01;

/** The edge all `cubes` share when they are cubes of one size (a map's resolution), else undefined. */
export function uniformEdge(cubes: VoxelCube[]): number | undefined {
  if (cubes.length === 0) return undefined;
  const res = cubes[0].size.x;
  if (!(res > 0) || !isFinite(res)) return undefined;
  for (const c of cubes) {
    const s = c.size;
    if (Math.abs(s.x - res) > 1e-6 || Math.abs(s.y - res) > 1e-6 || Math.abs(s.z - res) > 1e-6) return undefined;
  }
  return res;
}

function colorKey(c: Rgba): number {
  const q = (v: number) => Math.max(0, Math.min(255, Math.round(v * 255)));
  return (q(c.r) << 16) | (q(c.g) << 8) | q(c.b);
}

/** `cubes` (of edge `res`, m) on their grid; undefined when they would span more than 4M cells. A cell given
 *  twice keeps the last colour. */
export function voxelGrid(cubes: VoxelCube[], res: number): VoxelGrid | undefined {
  if (cubes.length === 0) return undefined;
  const p0 = cubes[0].pose.position;
  // Cell indices relative to the first voxel: exact whether centres lie on multiples of res or half-way.
  const idx = new Int32Array(cubes.length * 3);
  const lo = [Infinity, Infinity, Infinity], hi = [-Infinity, -Infinity, -Infinity];
  cubes.forEach((c, n) => {
    const p = c.pose.position;
    const ijk = [Math.round((p.x - p0.x) / res), Math.round((p.y - p0.y) / res), Math.round((p.z - p0.z) / res)];
    for (let a = 0; a < 3; a++) {
      idx[n * 3 + a] = ijk[a];
      lo[a] = Math.min(lo[a], ijk[a]);
      hi[a] = Math.max(hi[a], ijk[a]);
    }
  });
  const dims: [number, number, number] = [hi[0] - lo[0] + 1, hi[1] - lo[1] + 1, hi[2] - lo[2] + 1];
  if (!dims.every(isFinite) || dims[0] * dims[1] * dims[2] > kMaxCells) return undefined;
  const cells = new Int32Array(dims[0] * dims[1] * dims[2]);
  cubes.forEach((c, n) => {
    const i = idx[n * 3] - lo[0], j = idx[n * 3 + 1] - lo[1], k = idx[n * 3 + 2] - lo[2];
    cells[i + dims[0] * (j + dims[1] * k)] = 1 + colorKey(c.color);
  });
  const origin: [number, number, number] = [p0.x + lo[0] * res, p0.y + lo[1] * res, p0.z + lo[2] * res];
  return { res, origin, dims, cells };
}

/** The cell value at integer (i, j, k) of `g`, 0 outside it. */
export function cellAt(g: VoxelGrid, i: number, j: number, k: number): number {
  const [nx, ny, nz] = g.dims;
  if (i < 0 || j < 0 || k < 0 || i >= nx || j >= ny || k >= nz) return 0;
  return g.cells[i + nx * (j + ny * k)];
}

/** The same space at twice the edge: a coarse cell is filled when any of its 8 cells is. Each coarse layer
 *  takes one colour, the one most of its fine voxels have (the map is coloured by height: the colour of that
 *  height band), so that a rough floor seen from far away merges into few rectangles. */
export function coarsen(g: VoxelGrid): VoxelGrid {
  const dims: [number, number, number] = [Math.ceil(g.dims[0] / 2), Math.ceil(g.dims[1] / 2), Math.ceil(g.dims[2] / 2)];
  const cells = new Int32Array(dims[0] * dims[1] * dims[2]);
  const layerColours = Array.from({ length: dims[2] }, () => new Map<number, number>());
  for (let k = 0; k < g.dims[2]; k++) {
    for (let j = 0; j < g.dims[1]; j++) {
      for (let i = 0; i < g.dims[0]; i++) {
        const v = g.cells[i + g.dims[0] * (j + g.dims[1] * k)];
        if (v === 0) continue;
        cells[(i >> 1) + dims[0] * ((j >> 1) + dims[1] * (k >> 1))] = 1;
        const counts = layerColours[k >> 1];
        counts.set(v, (counts.get(v) ?? 0) + 1);
      }
    }
  }
  const layerSize = dims[0] * dims[1];
  for (let k = 0; k < dims[2]; k++) {
    let colour = 0, most = 0;
    for (const [v, n] of layerColours[k]) if (n > most || (n === most && v > colour)) [colour, most] = [v, n];
    for (let c = k * layerSize; c < (k + 1) * layerSize; c++) if (cells[c] !== 0) cells[c] = colour;
  }
  // The coarse cell (0, 0, 0) spans fine cells 0 and 1: its centre is half a fine cell further.
  const h = g.res / 2;
  return { res: g.res * 2, origin: [g.origin[0] + h, g.origin[1] + h, g.origin[2] + h], dims, cells };
}

/**
 * The visible faces of `g` (all but bottoms: the map is seen from above), coplanar neighbours of one colour
 * merged into rectangles. Positions relative to `centre` (m, map frame); faces wound counter-clockwise seen
 * from outside (front faces for three.js).
 */
export function meshGrid(g: VoxelGrid, centre: [number, number, number]): VoxelMesh {
  const positions: number[] = [];
  const colors: number[] = [];
  const indices: number[] = [];
  let quads = 0;
  const res = g.res;
  for (let a = 0; a < 3; a++) {
    for (const s of [1, -1]) {
      if (a === 2 && s === -1) continue; // bottoms are never seen from above
      const u = (a + 1) % 3, v = (a + 2) % 3;
      const nu = g.dims[u], nv = g.dims[v];
      const shade = a === 2 ? kShadeTop : a === 0 ? kShadeX : kShadeY;
      const mask = new Int32Array(nu * nv);
      const at = [0, 0, 0];
      for (let k = 0; k < g.dims[a]; k++) {
        // The faces of slice k that look onto empty space along s.
        let any = false;
        for (let jv = 0; jv < nv; jv++) {
          for (let iu = 0; iu < nu; iu++) {
            at[a] = k, at[u] = iu, at[v] = jv;
            const c = cellAt(g, at[0], at[1], at[2]);
            at[a] = k + s;
            const visible = c !== 0 && cellAt(g, at[0], at[1], at[2]) === 0;
            mask[iu + nu * jv] = visible ? c : 0;
            any ||= visible;
          }
        }
        if (!any) continue;
        // Greedy rectangles of one colour: widest run along u, then as many rows along v as match it.
        for (let jv = 0; jv < nv; jv++) {
          for (let iu = 0; iu < nu;) {
            const c = mask[iu + nu * jv];
            if (c === 0) {
              iu++;
              continue;
            }
            let w = 1;
            while (iu + w < nu && mask[iu + w + nu * jv] === c) w++;
            let h = 1;
            rows: for (; jv + h < nv; h++) {
              for (let x = 0; x < w; x++) if (mask[iu + x + nu * (jv + h)] !== c) break rows;
            }
            for (let y = 0; y < h; y++) mask.fill(0, iu + nu * (jv + y), iu + w + nu * (jv + y));
            // The rectangle's corners on the face plane, 1 % of a voxel wider on each side: where a corner of
            // one rectangle lies on another's edge (a T-junction), rounding would leave pixel-wide cracks.
            const plane = g.origin[a] + (k + s * 0.5) * res - centre[a];
            const u0 = g.origin[u] + (iu - 0.5) * res - centre[u] - kOverlap * res, u1 = u0 + (w + 2 * kOverlap) * res;
            const v0 = g.origin[v] + (jv - 0.5) * res - centre[v] - kOverlap * res, v1 = v0 + (h + 2 * kOverlap) * res;
            const base = positions.length / 3;
            for (const [cu, cv] of [[u0, v0], [u1, v0], [u1, v1], [u0, v1]]) {
              const p = [0, 0, 0];
              p[a] = plane, p[u] = cu, p[v] = cv;
              positions.push(p[0], p[1], p[2]);
              const rgb = c - 1;
              colors.push((((rgb >> 16) & 255) / 255) * shade, (((rgb >> 8) & 255) / 255) * shade, ((rgb & 255) / 255) * shade);
            }
            // u x v points along +a (u, v follow a cyclically): that order faces +a, reversed faces -a.
            if (s > 0) indices.push(base, base + 1, base + 2, base, base + 2, base + 3);
            else indices.push(base, base + 2, base + 1, base, base + 3, base + 2);
            quads++;
            iu += w;
          }
        }
      }
    }
  }
  return { centre, positions: new Float32Array(positions), colors: new Float32Array(colors), indices: new Uint32Array(indices), quads };
}

/** The centre of `g`'s bounding box, m. */
export function gridCentre(g: VoxelGrid): [number, number, number] {
  return [0, 1, 2].map((a) => g.origin[a] + ((g.dims[a] - 1) * g.res) / 2) as [number, number, number];
}
