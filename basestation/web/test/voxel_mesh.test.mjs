// The map mesher (src/voxel_mesh.ts, as the build emits it): visible faces only, coplanar faces of one colour
// merged, outward winding, the coarse level, and columns it must leave to boxes.
import assert from "node:assert/strict";
import { join } from "node:path";
import { test } from "node:test";
import { pathToFileURL } from "node:url";

import { BUILD } from "./harness.mjs";

const { coarsen, gridCentre, meshGrid, uniformEdge, voxelGrid, cellAt } = await import(
  pathToFileURL(join(BUILD, "web", "voxel_mesh.mjs")).href);

const grey = { r: 0.5, g: 0.5, b: 0.5, a: 1 };
const cube = (x, y, z, color = grey, res = 0.2) =>
  ({ pose: { position: { x, y, z } }, size: { x: res, y: res, z: res }, color });

// The faces' outward normals: (b - a) x (c - a) of each triangle.
function normals(mesh) {
  const p = mesh.positions, out = [];
  for (let t = 0; t < mesh.indices.length; t += 3) {
    const [a, b, c] = [0, 1, 2].map((k) => mesh.indices[t + k] * 3);
    const u = [p[b] - p[a], p[b + 1] - p[a + 1], p[b + 2] - p[a + 2]];
    const v = [p[c] - p[a], p[c + 1] - p[a + 1], p[c + 2] - p[a + 2]];
    const n = [u[1] * v[2] - u[2] * v[1], u[2] * v[0] - u[0] * v[2], u[0] * v[1] - u[1] * v[0]];
    const len = Math.hypot(...n);
    out.push(n.map((x) => Math.round(x / len)));
  }
  return out;
}

test("one voxel: five faces (no bottom), each facing out of the voxel", () => {
  const g = voxelGrid([cube(1.1, 2.1, 0.1)], 0.2);
  const mesh = meshGrid(g, gridCentre(g));
  assert.equal(mesh.quads, 5);
  const seen = new Set(normals(mesh).map((n) => n.join(",")));
  assert.deepEqual([...seen].sort(), ["-1,0,0", "0,-1,0", "0,0,1", "0,1,0", "1,0,0"].sort());
  // Corners at the voxel's faces: 0.1 m from its centre (which is the grid's centre here), the rectangles 1 %
  // of a voxel wider on each side.
  for (const v of mesh.positions) assert.ok(Math.abs(Math.abs(v) - 0.1) < 0.0021, `${v}`);
});

test("a flat floor of one colour is one rectangle on top and one per side", () => {
  const cubes = [];
  for (let i = 0; i < 20; i++) for (let j = 0; j < 20; j++) cubes.push(cube(i * 0.2 + 0.1, j * 0.2 + 0.1, 0.1));
  const g = voxelGrid(cubes, 0.2);
  const mesh = meshGrid(g, gridCentre(g));
  assert.equal(mesh.quads, 5);
  // Its top covers the whole 4 x 4 m column at z = 0.2.
  const zs = new Set(), xs = [];
  for (let k = 0; k < mesh.positions.length; k += 3) {
    xs.push(mesh.positions[k] + gridCentre(g)[0]);
    zs.add(Math.round((mesh.positions[k + 2] + gridCentre(g)[2]) * 100) / 100 + 0);
  }
  assert.ok(Math.abs(Math.min(...xs)) < 0.0021 && Math.abs(Math.max(...xs) - 4) < 0.0021, `${Math.min(...xs)} ${Math.max(...xs)}`);
  assert.deepEqual([...zs].sort(), [0, 0.2]);
});

test("faces between two voxels are not drawn; colours are not merged across", () => {
  const red = { r: 0.9, g: 0.3, b: 0.2, a: 1 };
  // Two voxels side by side along x, of one colour: 8 faces (2 tops merged into 1 ... sides merged).
  let g = voxelGrid([cube(0.1, 0.1, 0.1), cube(0.3, 0.1, 0.1)], 0.2);
  assert.equal(meshGrid(g, gridCentre(g)).quads, 5); // top, 2 long sides merged, 2 ends
  g = voxelGrid([cube(0.1, 0.1, 0.1), cube(0.3, 0.1, 0.1, red)], 0.2);
  assert.equal(meshGrid(g, gridCentre(g)).quads, 8); // the same faces, none merged across the colours
  // A stack of two: the lower voxel's top is hidden, the upper one's bottom is never drawn.
  g = voxelGrid([cube(0.1, 0.1, 0.1), cube(0.1, 0.1, 0.3)], 0.2);
  const mesh = meshGrid(g, gridCentre(g));
  assert.equal(normals(mesh).filter((n) => n[2] === 1).length, 2); // one top: two triangles
});

test("a rough floor keeps its steps: more than a flat one, far fewer than five faces a voxel", () => {
  const cubes = [];
  for (let i = 0; i < 20; i++) for (let j = 0; j < 20; j++) cubes.push(cube(i * 0.2 + 0.1, j * 0.2 + 0.1, (i * 7 + j * 3) % 5 === 0 ? 0.3 : 0.1));
  const g = voxelGrid(cubes, 0.2);
  const quads = meshGrid(g, gridCentre(g)).quads;
  assert.ok(quads > 5 && quads < cubes.length * 5 / 2, `${quads} rectangles for ${cubes.length} voxels`);
});

test("the coarse level: cells twice the size, filled where any of their eight is, each layer in its commonest colour", () => {
  const top = { r: 1, g: 1, b: 1, a: 1 };
  const g = voxelGrid([cube(0.1, 0.1, 0.1), cube(0.3, 0.3, 0.3, top), cube(0.9, 0.1, 0.1)], 0.2);
  const c = coarsen(g);
  assert.equal(c.res, 0.4);
  assert.deepEqual(c.dims, [3, 1, 1]);
  const greyKey = 1 + ((128 << 16) | (128 << 8) | 128);
  assert.equal(cellAt(c, 0, 0, 0), greyKey); // two grey voxels in the layer against one white
  assert.equal(cellAt(c, 1, 0, 0), 0);
  assert.equal(cellAt(c, 2, 0, 0), greyKey);
  // A rough floor (every other cell one voxel higher, another colour) is one rectangle on top from afar.
  const floor = [];
  for (let i = 0; i < 20; i++) for (let j = 0; j < 20; j++) floor.push((i + j) % 2 ? cube(i * 0.2 + 0.1, j * 0.2 + 0.1, 0.1) : cube(i * 0.2 + 0.1, j * 0.2 + 0.1, 0.3, top));
  const rough = voxelGrid(floor, 0.2);
  assert.ok(meshGrid(rough, gridCentre(rough)).quads > 100);
  assert.equal(meshGrid(coarsen(rough), gridCentre(rough)).quads, 5);
  // The coarse cell (0, 0, 0) spans x in [0, 0.4]: its centre is at 0.2.
  assert.ok(Math.abs(c.origin[0] - 0.2) < 1e-9, `${c.origin}`);
});

test("columns that are not cubes of one size, or that would span millions of cells, are left to boxes", () => {
  assert.equal(uniformEdge([cube(0, 0, 0), cube(1, 0, 0, grey, 0.4)]), undefined);
  assert.equal(uniformEdge([{ ...cube(0, 0, 0), size: { x: 0.2, y: 0.2, z: 0.5 } }]), undefined);
  assert.equal(uniformEdge([]), undefined);
  assert.equal(uniformEdge([cube(0, 0, 0), cube(0.2, 0, 0)]), 0.2);
  assert.equal(voxelGrid([cube(0, 0, 0), cube(500, 500, 500)], 0.2), undefined);
});
