// The fleet map in the 3D view (/fleet_map: one entity per 4 x 4 m column of voxels). Each column is meshed
// (voxel_mesh.ts: visible faces, merged) at three levels of detail, and the columns of a 16 x 16 m block are
// drawn together, one mesh per level: a 100 x 100 m map is ~40 draw calls instead of ~600, which is what a
// software renderer pays most for. Columns that are not cubes of one size are drawn box by box (instanced).
// Frame: the map frame, z up, metres.
import * as THREE from "three";

import { cellAt, coarsen, meshGrid, uniformEdge, voxelGrid, type VoxelCube, type VoxelGrid, type VoxelMesh } from "./voxel_mesh";

// Beyond these distances from the camera to a block's centre (m) its columns are drawn with voxels twice,
// then four times the size: about where a 0.2 m voxel gets smaller than 3, then 1.5 pixels at 800 px.
const kCoarseBeyondM = 60;
const kCoarserBeyondM = 110;
const kBlockM = 16;

interface Column {
  block: string;
  topZ: number; // the top of its highest voxel, m
  grid?: VoxelGrid; // merged columns
  levels?: VoxelMesh[]; // fine, coarse, coarser; relative to the block's centre
  boxes?: THREE.InstancedMesh; // columns drawn box by box
  voxels: number;
  quads: number;
}

interface Block {
  centre: [number, number, number];
  columns: Set<string>;
  lod?: THREE.LOD;
  fine?: THREE.Mesh;
  dirty: boolean;
}

/** The map's voxels as drawn: add, replace and remove columns, pick a surface. */
export class MapView {
  readonly group = new THREE.Group();
  /** Draw every column box by box (the frame-rate bench's baseline). */
  boxesOnly = false;
  voxelCount = 0;
  /** Rectangles of the finest level (merged faces, or 5 per voxel box by box). */
  quads = 0;
  private columns = new Map<string, Column>();
  private blocks = new Map<string, Block>();
  private material: THREE.MeshBasicMaterial;
  // Boxes: unlit, each face a fixed shade, bottom dropped; drawn 4 % smaller (a seam shows the grid), picked
  // at full size.
  private boxGeometry = MapView.shadedBoxGeometry().scale(0.96, 0.96, 0.96);
  private boxPickGeometry = new THREE.BoxGeometry(1, 1, 1);
  private boxMaterial: THREE.MeshBasicMaterial;

  constructor() {
    this.material = new THREE.MeshBasicMaterial({ vertexColors: true });
    this.boxMaterial = new THREE.MeshBasicMaterial({ vertexColors: true });
  }

  /** Hides the voxels above `plane` (the ceiling cut), or none (undefined). A clipping plane costs every
   *  pixel of the map a test and a discard in software GL: set only when it cuts something (see `topZ`). */
  setClipping(plane: THREE.Plane | undefined): void {
    const planes = plane ? [plane] : [];
    if (this.material.clippingPlanes?.length === planes.length) return;
    for (const m of [this.material, this.boxMaterial]) {
      m.clippingPlanes = planes;
      m.needsUpdate = true;
    }
  }

  /** The top of the highest voxel, m (map frame); -Infinity for an empty map. Recomputed only after the map
   *  changed (it is asked at every fleet update, as the ceiling follows the robots). */
  get topZ(): number {
    if (this.topStale) {
      this.top = -Infinity;
      for (const c of this.columns.values()) this.top = Math.max(this.top, c.topZ);
      this.topStale = false;
    }
    return this.top;
  }
  private top = -Infinity;
  private topStale = false;

  has(id: string): boolean {
    return this.columns.has(id);
  }

  ids(): string[] {
    return [...this.columns.keys()];
  }

  /** Replaces column `id` with `cubes` (none: removes it). Drawn at the next `flush`. */
  setColumn(id: string, cubes: VoxelCube[]): void {
    this.removeColumn(id);
    if (cubes.length === 0) return;
    const res = this.boxesOnly ? undefined : uniformEdge(cubes);
    const grid = res === undefined ? undefined : voxelGrid(cubes, res);
    let column: Column;
    if (grid) {
      const block = MapView.blockOf(grid);
      const centre = MapView.blockCentre(block);
      const coarse = coarsen(grid);
      const levels = [meshGrid(grid, centre), meshGrid(coarse, centre), meshGrid(coarsen(coarse), centre)];
      const topZ = grid.origin[2] + (grid.dims[2] - 0.5) * grid.res;
      column = { block, topZ, grid, levels, voxels: cubes.length, quads: levels[0].quads };
      this.blockFor(block).columns.add(id);
    } else {
      const boxes = this.boxes(cubes);
      this.group.add(boxes);
      const topZ = cubes.reduce((top, c) => Math.max(top, c.pose.position.z + c.size.z / 2), -Infinity);
      column = { block: "", topZ, boxes, voxels: cubes.length, quads: cubes.length * 5 };
    }
    this.columns.set(id, column);
    this.topStale = true;
    this.voxelCount += column.voxels;
    this.quads += column.quads;
  }

  removeColumn(id: string): void {
    const column = this.columns.get(id);
    if (!column) return;
    this.columns.delete(id);
    this.topStale = true;
    this.voxelCount -= column.voxels;
    this.quads -= column.quads;
    if (column.boxes) {
      this.group.remove(column.boxes);
      column.boxes.dispose();
    } else {
      const block = this.blocks.get(column.block);
      block?.columns.delete(id);
      if (block) block.dirty = true;
    }
  }

  /** Rebuilds the blocks whose columns changed since the last flush. */
  flush(): void {
    for (const [key, block] of this.blocks) {
      if (!block.dirty) continue;
      block.dirty = false;
      if (block.lod) {
        this.group.remove(block.lod);
        block.lod.traverse((o) => (o as THREE.Mesh).geometry?.dispose());
        block.lod = block.fine = undefined;
      }
      if (block.columns.size === 0) {
        this.blocks.delete(key);
        continue;
      }
      const levels = [0, 1, 2].map((l) => MapView.concatenate([...block.columns].map((id) => this.columns.get(id)!.levels![l])));
      const meshes = levels.map((m) => {
        const geometry = new THREE.BufferGeometry();
        geometry.setAttribute("position", new THREE.BufferAttribute(m.positions, 3));
        geometry.setAttribute("color", new THREE.BufferAttribute(m.colors, 3));
        geometry.setIndex(new THREE.BufferAttribute(m.indices, 1));
        geometry.computeBoundingSphere();
        return new THREE.Mesh(geometry, this.material);
      });
      const lod = new THREE.LOD();
      lod.position.set(...block.centre);
      lod.addLevel(meshes[0], 0);
      lod.addLevel(meshes[1], kCoarseBeyondM);
      lod.addLevel(meshes[2], kCoarserBeyondM);
      lod.updateMatrixWorld(true);
      lod.userData.kind = "map";
      meshes[0].userData.block = key; // picking looks for the hit voxel in this block's columns only
      this.group.add(lod);
      block.lod = lod;
      block.fine = meshes[0];
    }
  }

  /**
   * The top of the first voxel `raycaster` meets at or below `ceilingZ` (map frame, z at the voxel's top, m)
   * when it is a surface to stand on (nothing within two voxels above it); undefined when the ray meets a
   * side (a wall), a covered top, or nothing.
   */
  pickSurface(raycaster: THREE.Raycaster, ceilingZ: number): THREE.Vector3 | undefined {
    const pickable: THREE.Object3D[] = [];
    const boxes: THREE.InstancedMesh[] = [];
    for (const block of this.blocks.values()) if (block.fine) pickable.push(block.fine);
    for (const column of this.columns.values()) if (column.boxes) boxes.push(column.boxes);
    for (const mesh of boxes) mesh.geometry = this.boxPickGeometry; // full size: a tap on a seam meets it
    let hits: THREE.Intersection[];
    try {
      hits = raycaster.intersectObjects([...pickable, ...boxes], false);
    } finally {
      for (const mesh of boxes) mesh.geometry = this.boxGeometry;
    }
    // Voxels above the ceiling cut are not drawn (a clipping plane, which raycasting ignores): passed over.
    for (const hit of hits) {
      if (hit.point.z > ceilingZ) continue;
      const top = hit.face !== null && hit.face !== undefined && hit.face.normal.z > 0.5;
      if (top && !this.coveredAbove(hit)) return hit.point.clone();
      return undefined;
    }
    return undefined;
  }

  // True when the voxel whose top `hit` meets has another voxel within two voxel sizes above it: the top of a
  // wall cut by the ceiling, not a surface to stand on.
  private coveredAbove(hit: THREE.Intersection): boolean {
    if (hit.object instanceof THREE.InstancedMesh) return MapView.boxCoveredAbove(hit.object, hit.instanceId);
    const block = this.blocks.get(hit.object.userData.block as string);
    for (const id of block?.columns ?? []) {
      const g = this.columns.get(id)?.grid;
      if (!g) continue;
      const cell = (a: number, v: number) => Math.round((v - g.origin[a]) / g.res);
      const i = cell(0, hit.point.x), j = cell(1, hit.point.y), k = cell(2, hit.point.z - g.res / 2);
      if (cellAt(g, i, j, k) === 0) continue; // not this column's voxel
      return cellAt(g, i, j, k + 1) !== 0 || cellAt(g, i, j, k + 2) !== 0;
    }
    return false;
  }

  private static boxCoveredAbove(mesh: THREE.InstancedMesh, index: number | undefined): boolean {
    if (index === undefined) return false;
    const m = new THREE.Matrix4();
    const p = new THREE.Vector3(), q = new THREE.Vector3(), size = new THREE.Vector3(), quat = new THREE.Quaternion();
    mesh.getMatrixAt(index, m);
    m.decompose(p, quat, size);
    for (let i = 0; i < mesh.count; i++) {
      if (i === index) continue;
      mesh.getMatrixAt(i, m);
      q.setFromMatrixPosition(m);
      const dz = q.z - p.z;
      if (dz > 0 && dz < 2.2 * size.z && Math.abs(q.x - p.x) < 0.5 * size.x && Math.abs(q.y - p.y) < 0.5 * size.y) return true;
    }
    return false;
  }

  private blockFor(key: string): Block {
    let block = this.blocks.get(key);
    if (!block) this.blocks.set(key, (block = { centre: MapView.blockCentre(key), columns: new Set(), dirty: true }));
    block.dirty = true;
    return block;
  }

  // The 16 x 16 m block of a column: the one holding its grid's first cell.
  private static blockOf(g: VoxelGrid): string {
    return `${Math.floor(g.origin[0] / kBlockM)}/${Math.floor(g.origin[1] / kBlockM)}`;
  }

  private static blockCentre(key: string): [number, number, number] {
    const [i, j] = key.split("/").map(Number);
    return [(i + 0.5) * kBlockM, (j + 0.5) * kBlockM, 0];
  }

  private static concatenate(meshes: VoxelMesh[]): VoxelMesh {
    const count = (f: (m: VoxelMesh) => number) => meshes.reduce((n, m) => n + f(m), 0);
    const positions = new Float32Array(count((m) => m.positions.length));
    const colors = new Float32Array(count((m) => m.colors.length));
    const indices = new Uint32Array(count((m) => m.indices.length));
    let p = 0, i = 0;
    for (const m of meshes) {
      positions.set(m.positions, p);
      colors.set(m.colors, p);
      const base = p / 3;
      for (let k = 0; k < m.indices.length; k++) indices[i + k] = m.indices[k] + base;
      p += m.positions.length;
      i += m.indices.length;
    }
    return { centre: meshes[0]?.centre ?? [0, 0, 0], positions, colors, indices, quads: count((m) => m.quads) };
  }

  private boxes(cubes: VoxelCube[]): THREE.InstancedMesh {
    const mesh = new THREE.InstancedMesh(this.boxGeometry, this.boxMaterial, cubes.length);
    const m = new THREE.Matrix4();
    const c = new THREE.Color();
    cubes.forEach((cube, i) => {
      const p = cube.pose.position;
      m.makeScale(cube.size.x, cube.size.y, cube.size.z);
      m.setPosition(p.x, p.y, p.z);
      mesh.setMatrixAt(i, m);
      c.setRGB(cube.color.r, cube.color.g, cube.color.b);
      mesh.setColorAt(i, c);
    });
    mesh.instanceMatrix.needsUpdate = true;
    if (mesh.instanceColor) mesh.instanceColor.needsUpdate = true;
    mesh.geometry = this.boxPickGeometry; // the bounds of the voxels' full size (culling and picking)
    mesh.computeBoundingSphere();
    mesh.geometry = this.boxGeometry;
    mesh.userData.kind = "map";
    return mesh;
  }

  /** A unit box (Z up) without its bottom face, each face's vertices coloured by a fixed shade. */
  static shadedBoxGeometry(): THREE.BufferGeometry {
    const box = new THREE.BoxGeometry(1, 1, 1);
    const normals = box.getAttribute("normal");
    const shades = new Float32Array(normals.count * 3);
    for (let i = 0; i < normals.count; i++) {
      const nx = normals.getX(i), nz = normals.getZ(i);
      const shade = nz > 0.5 ? 1.0 : nz < -0.5 ? 0.45 : Math.abs(nx) > 0.5 ? 0.8 : 0.66;
      shades.set([shade, shade, shade], i * 3);
    }
    box.setAttribute("color", new THREE.BufferAttribute(shades, 3));
    // BoxGeometry's faces in index order: +x, -x, +y, -y, +z, -z (6 indices each); -z (the bottom) is dropped.
    const index = box.getIndex()!;
    box.setIndex(new THREE.BufferAttribute((index.array as Uint16Array).slice(0, 30), 1));
    box.clearGroups();
    box.deleteAttribute("normal");
    box.deleteAttribute("uv");
    return box;
  }
}
