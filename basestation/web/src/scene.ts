// The 3D fleet view (three.js): the fleet map's voxels as one instanced mesh per map column entity, robots with
// heading, name, mode colour and lock holder, global paths, local plans, trails, goals and staircases drawn as
// steps. Frame: the map frame, z up, metres.
import * as THREE from "three";
import { OrbitControls } from "three/examples/jsm/controls/OrbitControls.js";

export interface RobotPose {
  id: string;
  x: number;
  y: number;
  z: number;
  yaw: number;
  mode: string;
  holder: string;
  online: boolean;
}

const MODE_COLORS: Record<string, number> = {
  idle: 0x9ea3ad,
  manual: 0xf58c26,
  smart_joystick: 0xa361eb,
  waypoint: 0x338cfa,
  convoy: 0xd9b52b,  // explore (and any other mode): 0x26b8a6
};

export function modeColor(mode: string): string {
  return "#" + (MODE_COLORS[mode] ?? 0x26b8a6).toString(16).padStart(6, "0");
}

type Vec3 = { x: number; y: number; z: number };
type Rgba = { r: number; g: number; b: number; a: number };

interface RobotObject {
  group: THREE.Group;
  body: THREE.Mesh;
  ring: THREE.Mesh;
  label: THREE.Sprite;
  labelText: string;
}

export class FleetScene {
  readonly renderer: THREE.WebGLRenderer;
  readonly scene = new THREE.Scene();
  readonly camera: THREE.PerspectiveCamera;
  readonly controls: OrbitControls;
  private mapGroup = new THREE.Group();
  private chunks = new Map<string, THREE.InstancedMesh>();
  private entityGroup = new THREE.Group(); // paths, staircases
  private entities = new Map<string, THREE.Object3D>();
  private robots = new Map<string, RobotObject>();
  private boxGeometry = new THREE.BoxGeometry(1, 1, 1);
  // Voxels above the ceiling cut are clipped away, so that robots inside tunnels and rooms stay in view.
  private ceilingPlane = new THREE.Plane(new THREE.Vector3(0, 0, -1), 1e6);
  // Voxels: an unlit material on a box whose faces carry a fixed shade (top brightest, bottom never drawn), so
  // that 300k instances cost no lighting per pixel and 5/6 of the triangles.
  // Voxels are drawn 4 % smaller than they are (a dark seam shows the grid) but picked at their full size: a tap
  // on a seam still meets the surface.
  private voxelGeometry = FleetScene.shadedVoxelGeometry().scale(0.96, 0.96, 0.96);
  private voxelPickGeometry = new THREE.BoxGeometry(1, 1, 1);
  private voxelMaterial = new THREE.MeshBasicMaterial({ vertexColors: true, clippingPlanes: [this.ceilingPlane] });
  /** Height (metres, map frame) above which map voxels are hidden; Infinity shows all. */
  ceilingCut = Infinity;
  private raycaster = new THREE.Raycaster();
  private topDown = false;
  private frames = 0;
  private fpsWindowStart = performance.now();
  fps = 0;
  /** Frames drawn since the page opened. */
  framesDrawn = 0;
  voxelCount = 0;
  selected = "";
  private centred = false;
  private dirty = true;
  private robotsKey = "";
  private lastFrameMs = 0;
  /** WebGL renders in software (no GPU): antialiasing off, pixel ratio 1. */
  readonly softwareGl: boolean;
  /** Draw every animation frame even when nothing changed (the frame-rate bench). */
  continuous = false;

  /** Asks for a frame (after a change of the scene that the next animation frame must show). */
  invalidate(): void {
    this.dirty = true;
  }

  constructor(private container: HTMLElement) {
    // Software rendering (no GPU: SwiftShader, llvmpipe) draws a frame in ~100 ms: no antialiasing there and
    // one pixel per CSS pixel, so that the page keeps up with the fleet.
    this.softwareGl = FleetScene.isSoftwareGl();
    this.renderer = new THREE.WebGLRenderer({ antialias: !this.softwareGl, preserveDrawingBuffer: true });
    this.renderer.setPixelRatio(this.softwareGl ? 1 : Math.min(window.devicePixelRatio, 2));
    this.renderer.setClearColor(0x151a21);
    this.renderer.localClippingEnabled = true;
    container.appendChild(this.renderer.domElement);
    this.camera = new THREE.PerspectiveCamera(55, 1, 0.05, 2000);
    this.camera.up.set(0, 0, 1);
    this.camera.position.set(-6, -9, 12);
    this.controls = new OrbitControls(this.camera, this.renderer.domElement);
    this.controls.enableDamping = true;
    this.controls.screenSpacePanning = true;
    this.controls.touches = { ONE: THREE.TOUCH.ROTATE, TWO: THREE.TOUCH.DOLLY_PAN };
    this.scene.add(new THREE.HemisphereLight(0xdfe8ff, 0x30343a, 2.2));
    const sun = new THREE.DirectionalLight(0xffffff, 1.6);
    sun.position.set(20, -10, 40);
    this.scene.add(sun);
    const grid = new THREE.GridHelper(200, 200, 0x2d3640, 0x232a32);
    grid.rotation.x = Math.PI / 2; // the XY plane
    grid.position.z = -0.02;
    this.scene.add(grid);
    this.scene.add(this.mapGroup, this.entityGroup);
    new ResizeObserver(() => this.resize()).observe(container);
    this.resize();
    this.controls.addEventListener("change", () => this.invalidate());
    // Draws a frame only when something changed (or continuously for the frame-rate bench): an idle view
    // costs nothing, and the page's main thread stays free for the /fleet and /events messages.
    const loop = () => {
      const moved = this.controls.update();
      // In software at most 5 frames per second (each takes ~70 ms of the main thread there).
      const early = this.softwareGl && !this.continuous && performance.now() - this.lastFrameMs < 200;
      if (!(this.dirty || moved || this.continuous) || early) {
        if (moved) this.dirty = true;
        requestAnimationFrame(loop);
        return;
      }
      this.lastFrameMs = performance.now();
      this.dirty = false;
      this.renderer.render(this.scene, this.camera);
      this.frames++;
      this.framesDrawn++;
      const now = performance.now();
      if (now - this.fpsWindowStart >= 1000) {
        this.fps = (this.frames * 1000) / (now - this.fpsWindowStart);
        this.frames = 0;
        this.fpsWindowStart = now;
      }
      requestAnimationFrame(loop);
    };
    requestAnimationFrame(loop);
  }

  /** A unit box (Z up) without its bottom face, each face's vertices coloured by a fixed shade. */
  static shadedVoxelGeometry(): THREE.BufferGeometry {
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

  /** True when WebGL renders in software (the renderer string names SwiftShader, llvmpipe or software). */
  static isSoftwareGl(): boolean {
    const gl = document.createElement("canvas").getContext("webgl2");
    if (!gl) return true;
    const info = gl.getExtension("WEBGL_debug_renderer_info");
    const name = String(info ? gl.getParameter(info.UNMASKED_RENDERER_WEBGL) : gl.getParameter(gl.RENDERER));
    gl.getExtension("WEBGL_lose_context")?.loseContext();
    return /swiftshader|llvmpipe|software/i.test(name);
  }

  private resize(): void {
    this.invalidate();
    const w = Math.max(1, this.container.clientWidth);
    const h = Math.max(1, this.container.clientHeight);
    this.renderer.setSize(w, h, false);
    this.camera.aspect = w / h;
    this.camera.updateProjectionMatrix();
  }

  /** Orbit (false) or top-down (true) camera over the current target. */
  setTopDown(on: boolean): void {
    this.invalidate();
    this.topDown = on;
    const t = this.controls.target;
    const d = Math.max(8, this.camera.position.distanceTo(t));
    if (on) {
      this.camera.position.set(t.x, t.y - 0.001, t.z + d);
      this.controls.enableRotate = false;
    } else {
      this.camera.position.set(t.x - d * 0.45, t.y - d * 0.6, t.z + d * 0.65);
      this.controls.enableRotate = true;
    }
  }
  get isTopDown(): boolean {
    return this.topDown;
  }

  /** Hides map voxels above `z` metres (Infinity: none hidden). */
  setCeilingCut(z: number): void {
    if (z === this.ceilingCut) return;
    this.invalidate();
    this.ceilingCut = z;
    this.ceilingPlane.constant = isFinite(z) ? z : 1e6;
  }

  /** Moves the camera back along its viewing direction (top-down or orbit) until every point (map frame, m)
   *  is in view, with a 3 m margin, centred on their bounding box. No points: nothing changes. */
  frame(points: { x: number; y: number; z: number }[]): void {
    if (points.length === 0) return;
    this.invalidate();
    const box = new THREE.Box3().setFromPoints(points.map((p) => new THREE.Vector3(p.x, p.y, p.z)));
    const centre = box.getCenter(new THREE.Vector3());
    const radius = box.getSize(new THREE.Vector3()).length() / 2 + 3;
    const halfFov = THREE.MathUtils.degToRad(this.camera.fov) / 2;
    const distance = Math.max(radius / Math.sin(halfFov), radius / Math.sin(Math.atan(Math.tan(halfFov) * this.camera.aspect)));
    const direction = this.camera.position.clone().sub(this.controls.target).normalize();
    this.controls.target.copy(centre);
    this.camera.position.copy(centre).addScaledVector(direction, distance);
    this.camera.far = Math.max(this.camera.far, distance * 4);
    this.camera.updateProjectionMatrix();
  }

  /** Centres the view on a point (map frame). */
  focus(x: number, y: number, z: number): void {
    this.invalidate();
    const offset = this.camera.position.clone().sub(this.controls.target);
    this.controls.target.set(x, y, z);
    this.camera.position.copy(this.controls.target).add(offset);
  }

  /** A foxglove.SceneUpdate of /fleet_map, /paths or /staircases. */
  applySceneUpdate(update: any): void {
    this.invalidate();
    for (const d of update.deletions ?? []) {
      if (d.type === 1) {
        this.clearAll();
      } else {
        this.remove(d.id);
      }
    }
    for (const e of update.entities ?? []) {
      if (typeof e.id !== "string") continue;
      if (e.id.startsWith("map/")) {
        this.setChunk(e.id, e.cubes ?? []);
      } else {
        this.setEntity(e);
      }
    }
  }

  private clearAll(): void {
    for (const id of [...this.chunks.keys(), ...this.entities.keys()]) this.remove(id);
  }

  private remove(id: string): void {
    const chunk = this.chunks.get(id);
    if (chunk) {
      this.voxelCount -= chunk.count;
      this.mapGroup.remove(chunk);
      chunk.dispose();
      this.chunks.delete(id);
    }
    const obj = this.entities.get(id);
    if (obj) {
      this.entityGroup.remove(obj);
      this.entities.delete(id);
    }
  }

  /** One map column: its occupied voxels as instances of one box. */
  setChunk(id: string, cubes: { pose: { position: Vec3 }; size: Vec3; color: Rgba }[]): void {
    this.invalidate();
    this.remove(id);
    if (cubes.length === 0) return;
    const mesh = new THREE.InstancedMesh(this.voxelGeometry, this.voxelMaterial, cubes.length);
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
    mesh.geometry = this.voxelPickGeometry; // the bounds of the voxels' full size (culling and picking)
    mesh.computeBoundingSphere();
    mesh.geometry = this.voxelGeometry;
    mesh.userData.kind = "map";
    this.mapGroup.add(mesh);
    this.chunks.set(id, mesh);
    this.voxelCount += cubes.length;
    if (!this.centred && this.robots.size === 0) {
      const p = cubes[0].pose.position;
      this.focus(p.x, p.y, 0);
      this.centred = true;
    }
  }

  /** Paths, local plans, trails, goals (/paths) and staircases (/staircases): lines, cubes and spheres. */
  private setEntity(e: any): void {
    this.remove(e.id);
    const group = new THREE.Group();
    for (const line of e.lines ?? []) {
      const pts = (line.points ?? []).map((p: Vec3) => new THREE.Vector3(p.x, p.y, p.z));
      if (pts.length < 2) continue;
      const geometry = new THREE.BufferGeometry().setFromPoints(pts);
      const material = new THREE.LineBasicMaterial({
        color: new THREE.Color(line.color.r, line.color.g, line.color.b),
        transparent: line.color.a < 1,
        opacity: line.color.a,
      });
      group.add(new THREE.Line(geometry, material));
    }
    for (const cube of e.cubes ?? []) {
      const material = new THREE.MeshLambertMaterial({
        color: new THREE.Color(cube.color.r, cube.color.g, cube.color.b),
        transparent: cube.color.a < 1,
        opacity: cube.color.a,
      });
      const mesh = new THREE.Mesh(this.boxGeometry, material);
      mesh.scale.set(cube.size.x, cube.size.y, cube.size.z);
      const p = cube.pose.position;
      const q = cube.pose.orientation;
      mesh.position.set(p.x, p.y, p.z);
      mesh.quaternion.set(q.x, q.y, q.z, q.w);
      group.add(mesh);
    }
    for (const sphere of e.spheres ?? []) {
      const mesh = new THREE.Mesh(
        new THREE.SphereGeometry(0.5, 16, 12),
        new THREE.MeshLambertMaterial({ color: new THREE.Color(sphere.color.r, sphere.color.g, sphere.color.b) }),
      );
      mesh.scale.set(sphere.size.x, sphere.size.y, sphere.size.z);
      mesh.position.set(sphere.pose.position.x, sphere.pose.position.y, sphere.pose.position.z);
      group.add(mesh);
    }
    group.userData.id = e.id;
    this.entityGroup.add(group);
    this.entities.set(e.id, group);
  }

  /** Robots from /fleet: bodies (mode colour), heading, a label with name, mode and holder. */
  setRobots(poses: RobotPose[]): void {
    // A frame only when something shown changed (robots standing still cost no frame at 10 Hz).
    const key = JSON.stringify(poses.map((r) => [r.id, r.x.toFixed(3), r.y.toFixed(3), r.z.toFixed(3), r.yaw.toFixed(3), r.mode, r.holder, r.online, r.id === this.selected]));
    if (key !== this.robotsKey) this.invalidate();
    this.robotsKey = key;
    const seen = new Set<string>();
    for (const r of poses) {
      seen.add(r.id);
      let obj = this.robots.get(r.id);
      if (!obj) {
        obj = this.makeRobot(r.id);
        this.robots.set(r.id, obj);
        this.scene.add(obj.group);
        if (!this.centred) {
          this.focus(r.x, r.y, r.z);
          this.centred = true;
        }
      }
      obj.group.position.set(r.x, r.y, r.z);
      obj.group.rotation.z = r.yaw;
      (obj.body.material as THREE.MeshLambertMaterial).color.set(modeColor(r.mode));
      (obj.body.material as THREE.MeshLambertMaterial).opacity = r.online ? 1 : 0.35;
      obj.ring.visible = r.id === this.selected;
      const text = `${r.id} · ${r.mode || "?"} · ${r.holder ? "held by " + r.holder : "free"}${r.online ? "" : " · LOST"}`;
      if (text !== obj.labelText) {
        obj.labelText = text;
        this.drawLabel(obj.label, text);
      }
    }
    for (const [id, obj] of this.robots) {
      if (!seen.has(id)) {
        this.scene.remove(obj.group);
        this.robots.delete(id);
      }
    }
  }

  private makeRobot(id: string): RobotObject {
    const group = new THREE.Group();
    const body = new THREE.Mesh(
      new THREE.BoxGeometry(0.7, 0.5, 0.35),
      new THREE.MeshLambertMaterial({ color: 0x9ea3ad, transparent: true }),
    );
    body.position.z = 0.2;
    body.userData.robotId = id;
    const nose = new THREE.Mesh(new THREE.ConeGeometry(0.14, 0.35, 12), new THREE.MeshLambertMaterial({ color: 0xffffff }));
    nose.rotation.z = -Math.PI / 2;
    nose.position.set(0.5, 0, 0.25);
    nose.userData.robotId = id;
    const ring = new THREE.Mesh(
      new THREE.RingGeometry(0.6, 0.75, 40),
      new THREE.MeshBasicMaterial({ color: 0xffe14d, side: THREE.DoubleSide }),
    );
    ring.position.z = 0.03;
    ring.visible = false;
    const label = new THREE.Sprite(new THREE.SpriteMaterial({ transparent: true, depthTest: false }));
    label.position.z = 1.1;
    label.renderOrder = 10;
    group.add(body, nose, ring, label);
    return { group, body, ring, label, labelText: "" };
  }

  private drawLabel(sprite: THREE.Sprite, text: string): void {
    const canvas = document.createElement("canvas");
    const ctx = canvas.getContext("2d")!;
    ctx.font = "bold 30px system-ui, sans-serif";
    const w = Math.ceil(ctx.measureText(text).width) + 24;
    canvas.width = w;
    canvas.height = 44;
    ctx.font = "bold 30px system-ui, sans-serif";
    ctx.fillStyle = "rgba(10, 14, 20, 0.78)";
    ctx.fillRect(0, 0, w, 44);
    ctx.fillStyle = "#ffffff";
    ctx.fillText(text, 12, 32);
    const material = sprite.material as THREE.SpriteMaterial;
    material.map?.dispose();
    material.map = new THREE.CanvasTexture(canvas);
    material.needsUpdate = true;
    sprite.scale.set((w / 44) * 0.45, 0.45, 1);
  }

  /**
   * What a tap at client pixel (x, y) hits: a robot id; else the top of the first visible map voxel under the
   * tap (`surface`: a floor, a tread, another level's floor; map frame, z at the voxel's top, m); else, when the
   * tap meets a voxel's side (a wall) or no voxel, the ground plane at `groundZ` (m).
   */
  pick(clientX: number, clientY: number, groundZ: number): { robot?: string; point?: THREE.Vector3; surface?: boolean } {
    const rect = this.renderer.domElement.getBoundingClientRect();
    const ndc = new THREE.Vector2(((clientX - rect.left) / rect.width) * 2 - 1, -((clientY - rect.top) / rect.height) * 2 + 1);
    this.raycaster.setFromCamera(ndc, this.camera);
    const robotMeshes: THREE.Object3D[] = [];
    for (const obj of this.robots.values()) robotMeshes.push(...obj.group.children.filter((c) => c.userData.robotId));
    const hitRobot = this.raycaster.intersectObjects(robotMeshes, false)[0];
    if (hitRobot) return { robot: hitRobot.object.userData.robotId as string };
    // Voxels above the ceiling cut are not drawn (a clipping plane, which raycasting ignores): passed over.
    const chunks = [...this.chunks.values()];
    for (const chunk of chunks) chunk.geometry = this.voxelPickGeometry;
    let hits: THREE.Intersection[];
    try {
      hits = this.raycaster.intersectObjects(chunks, false);
    } finally {
      for (const chunk of chunks) chunk.geometry = this.voxelGeometry;
    }
    for (const hit of hits) {
      if (hit.point.z > this.ceilingCut) continue;
      const top = hit.face !== null && hit.face !== undefined && hit.face.normal.z > 0.5;
      if (top && hit.instanceId !== undefined && !FleetScene.coveredAbove(hit.object as THREE.InstancedMesh, hit.instanceId)) {
        return { point: hit.point.clone(), surface: true };
      }
      break;
    }
    // The floor under the robot's level: the ground plane through groundZ (a goal names x and y; the level is the robot's).
    const plane = new THREE.Plane(new THREE.Vector3(0, 0, 1), -groundZ);
    const point = new THREE.Vector3();
    if (this.raycaster.ray.intersectPlane(plane, point)) return { point };
    return {};
  }

  /**
   * True when voxel `index` of a map column has another voxel right above it (within two voxel sizes): the top
   * of a wall cut by the ceiling, not a surface to stand on.
   */
  private static coveredAbove(mesh: THREE.InstancedMesh, index: number): boolean {
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

  /** Screen position (client pixels) of a map point, for tests and markers. */
  toScreen(x: number, y: number, z: number): { x: number; y: number } {
    const v = new THREE.Vector3(x, y, z).project(this.camera);
    const rect = this.renderer.domElement.getBoundingClientRect();
    return { x: rect.left + ((v.x + 1) / 2) * rect.width, y: rect.top + ((1 - v.y) / 2) * rect.height };
  }

  /**
   * Synthetic map of `count` voxels (a benchmark of the view, no server needed), laid out as cairn_base sends a
   * real one: 0.2 m voxels in 4 x 4 m columns, a floor of 100 x 100 m (250k voxels) and the rest as 2 m walls
   * every 10 m.
   */
  addSyntheticVoxels(count: number): void {
    this.invalidate();
    const res = 0.2, side = 500;
    const columns = new Map<string, { pose: { position: Vec3 }; size: Vec3; color: Rgba }[]>();
    const add = (ix: number, iy: number, iz: number) => {
      const key = `map/bench/${Math.floor(ix / 20)}/${Math.floor(iy / 20)}`;
      let cubes = columns.get(key);
      if (!cubes) columns.set(key, (cubes = []));
      const z = iz * res;
      cubes.push({ pose: { position: { x: ix * res, y: iy * res, z } }, size: { x: res, y: res, z: res },
        color: { r: 0.3 + 0.3 * z, g: 0.6, b: 0.85 - 0.2 * z, a: 1 } });
    };
    let made = 0;
    for (let j = 0; j < side * side && made < count; j++, made++) add(j % side, Math.floor(j / side), 0);
    for (let k = 0; made < count; k++, made++) {
      const perWall = side * 10; // 500 voxels long, 10 high
      const wall = Math.floor(k / perWall), w = k % perWall;
      add((wall % 10) * 50 + 25, w % side, 1 + Math.floor(w / side) + 10 * Math.floor(wall / 10));
    }
    for (const [id, cubes] of columns) this.setChunk(id, cubes);
    this.focus(50, 50, 0);
  }

}
