// The 3D fleet view (three.js): the fleet map's voxels as one instanced mesh per map column entity, robots in
// their own colours with heading and a label (name, mode, lock holder), global paths, local plans, trails,
// goals (also one being chosen), named places and staircases drawn as steps, a scale bar. Labels are HTML over
// the canvas, laid out after each frame so that none prints over another. Frame: the map frame, z up, metres.
import * as THREE from "three";
import { OrbitControls } from "three/examples/jsm/controls/OrbitControls.js";
import { Line2 } from "three/examples/jsm/lines/Line2.js";
import { LineGeometry } from "three/examples/jsm/lines/LineGeometry.js";
import { LineMaterial } from "three/examples/jsm/lines/LineMaterial.js";
import { MapView } from "./map_view";

export interface RobotPose {
  id: string;
  x: number;
  y: number;
  z: number;
  yaw: number;
  mode: string;
  holder: string;
  online: boolean;
  color: string; // "#rrggbb", the robot's colour in every view
}

/** A goal drawn in the 3D view: one being chosen (`pending`, before it is sent) or one the robot drives to.
 *  Map frame, m. */
export interface GoalMarker {
  robot: string;
  x: number;
  y: number;
  z: number;
  color: string;
  pending: boolean;
}

/** A label over the 3D view: what it names, where it is drawn (client pixels), whether it is shown. */
export interface LabelBox {
  key: string;
  kind: "robot" | "goal" | "place";
  text: string;
  shown: boolean;
  left: number;
  top: number;
  width: number;
  height: number;
}

// The order labels are placed in: a robot's first (never hidden, moved up out of the way), then goals (moved),
// then places (hidden where they would cover another).
const kLabelPriority = { robot: 0, goal: 1, place: 2 } as const;

interface Label {
  el: HTMLDivElement;
  kind: LabelBox["kind"];
  anchor: THREE.Vector3;
  text: string;
  width: number;
  height: number;
  box?: LabelBox;
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

// A foxglove.Color (sRGB components in [0, 1], as Foxglove reads them) as a three.js colour.
const sceneColor = (c: Rgba) => new THREE.Color().setRGB(c.r, c.g, c.b, THREE.SRGBColorSpace);

interface RobotObject {
  group: THREE.Group;
  body: THREE.Mesh;
  ring: THREE.Mesh;
}

export class FleetScene {
  readonly renderer: THREE.WebGLRenderer;
  readonly scene = new THREE.Scene();
  readonly camera: THREE.PerspectiveCamera;
  readonly controls: OrbitControls;
  /** The map's voxels (/fleet_map). */
  readonly map: MapView;
  private entityGroup = new THREE.Group(); // paths, staircases
  private entities = new Map<string, THREE.Object3D>();
  private robots = new Map<string, RobotObject>();
  private goals = new Map<string, THREE.Group>();
  private labels = new Map<string, Label>();
  private labelLayer: HTMLDivElement;
  private scaleBar: HTMLDivElement;
  private boxGeometry = new THREE.BoxGeometry(1, 1, 1);
  // Voxels above the ceiling cut are clipped away, so that robots inside tunnels and rooms stay in view.
  private ceilingPlane = new THREE.Plane(new THREE.Vector3(0, 0, -1), 1e6);
  /** Height (metres, map frame) above which map voxels are hidden; Infinity shows all. */
  ceilingCut = Infinity;
  private raycaster = new THREE.Raycaster();
  private topDown = false;
  private frames = 0;
  private fpsWindowStart = performance.now();
  fps = 0;
  /** Frames drawn since the page opened. */
  framesDrawn = 0;
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
    this.map = new MapView();
    container.appendChild(this.renderer.domElement);
    this.labelLayer = document.createElement("div");
    this.labelLayer.id = "labels";
    this.scaleBar = document.createElement("div");
    this.scaleBar.id = "scale-bar";
    this.scaleBar.innerHTML = "<div></div><span></span>";
    // First among the view's overlays: the confirm bar, requests and toasts paint over the labels.
    container.prepend(this.labelLayer, this.scaleBar);
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
    // A 5 m ground grid (a 1 m one is a grey haze at overview zoom and costs software GL a third of a frame).
    const grid = new THREE.GridHelper(200, 40, 0x2d3640, 0x232a32);
    grid.rotation.x = Math.PI / 2; // the XY plane
    grid.position.z = -0.02;
    this.scene.add(grid);
    this.scene.add(this.map.group, this.entityGroup);
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
      this.layoutLabels();
      this.updateScaleBar();
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
    this.updateClipping();
  }

  // The ceiling's clipping plane only while it cuts some voxel.
  private updateClipping(): void {
    this.map.setClipping(isFinite(this.ceilingCut) && this.ceilingCut < this.map.topZ ? this.ceilingPlane : undefined);
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
    this.map.flush();
    this.updateClipping();
  }

  /** Voxels in the map as drawn. */
  get voxelCount(): number {
    return this.map.voxelCount;
  }
  /** Rectangles of the map's finest level (merged faces, or 5 per voxel box by box). */
  get mapQuads(): number {
    return this.map.quads;
  }

  private clearAll(): void {
    for (const id of [...this.map.ids(), ...this.entities.keys()]) this.remove(id);
  }

  private remove(id: string): void {
    this.map.removeColumn(id);
    const obj = this.entities.get(id);
    if (obj) {
      this.entityGroup.remove(obj);
      this.entities.delete(id);
    }
    this.removeLabel(id);
  }

  /** One map column (drawn at the next `map.flush()`). */
  private setChunk(id: string, cubes: { pose: { position: Vec3 }; size: Vec3; color: Rgba }[]): void {
    this.invalidate();
    this.map.setColumn(id, cubes);
    if (cubes.length > 0 && !this.centred && this.robots.size === 0) {
      const p = cubes[0].pose.position;
      this.focus(p.x, p.y, 0);
      this.centred = true;
    }
  }

  /** Paths, local plans, trails, goals (/paths), staircases (/staircases) and named places (/places): lines
   *  (drawn a few pixels wide whatever the zoom), cubes, spheres and texts (as labels). */
  private setEntity(e: any): void {
    this.remove(e.id);
    const group = new THREE.Group();
    for (const line of e.lines ?? []) {
      const pts = (line.points ?? []) as Vec3[];
      if (pts.length < 2) continue;
      const geometry = new LineGeometry().setPositions(pts.flatMap((p) => [p.x, p.y, p.z]));
      const material = new LineMaterial({
        color: sceneColor(line.color).getHex(),
        // The schema's thickness (m) as pixels: a path 0.15 m thick is 4.5 px, none thinner than 2 px.
        linewidth: Math.min(6, Math.max(2, (line.thickness ?? 0.05) * 30)),
        transparent: line.color.a < 1,
        opacity: line.color.a,
        // Drawn over the map (a path lies on the floor's voxels, and runs under a cut ceiling's walls).
        depthTest: false,
      });
      const drawn = new Line2(geometry, material);
      drawn.renderOrder = 3;
      drawn.computeLineDistances();
      group.add(drawn);
    }
    for (const cube of e.cubes ?? []) {
      const material = new THREE.MeshLambertMaterial({
        color: sceneColor(cube.color),
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
        new THREE.MeshLambertMaterial({ color: sceneColor(sphere.color) }),
      );
      mesh.scale.set(sphere.size.x, sphere.size.y, sphere.size.z);
      mesh.position.set(sphere.pose.position.x, sphere.pose.position.y, sphere.pose.position.z);
      group.add(mesh);
    }
    const text = (e.texts ?? [])[0];
    if (text && e.id.startsWith("place/")) {
      const p = text.pose.position;
      this.setLabel(e.id, "place", text.text, new THREE.Vector3(p.x, p.y, p.z));
    }
    group.userData.id = e.id;
    this.entityGroup.add(group);
    this.entities.set(e.id, group);
  }

  /** Robots from /fleet: bodies in the robot's colour, heading, a label with name, mode and holder. */
  setRobots(poses: RobotPose[]): void {
    // A frame only when something shown changed (robots standing still cost no frame at 10 Hz).
    const key = JSON.stringify(poses.map((r) => [r.id, r.x.toFixed(3), r.y.toFixed(3), r.z.toFixed(3), r.yaw.toFixed(3), r.mode, r.holder, r.online, r.color, r.id === this.selected]));
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
      (obj.body.material as THREE.MeshLambertMaterial).color.set(r.color || "#9ea3ad");
      (obj.body.material as THREE.MeshLambertMaterial).opacity = r.online ? 1 : 0.35;
      obj.ring.visible = r.id === this.selected;
      const text = `${r.id} · ${r.mode || "?"} · ${r.holder ? "held by " + r.holder : "free"}${r.online ? "" : " · LOST"}`;
      const label = this.setLabel(`robot/${r.id}`, "robot", text, new THREE.Vector3(r.x, r.y, r.z + 1.0));
      label.el.style.borderLeftColor = r.color || "#9ea3ad";
      label.el.classList.toggle("lost", !r.online);
    }
    for (const [id, obj] of this.robots) {
      if (!seen.has(id)) {
        this.scene.remove(obj.group);
        this.robots.delete(id);
        this.removeLabel(`robot/${id}`);
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
    group.add(body, nose, ring);
    return { group, body, ring };
  }

  /**
   * The goals to draw, one per robot at most: a ring on the floor and a post in the robot's colour, faint
   * while it is being chosen (`pending`), solid once sent; with a label "r1 goal".
   */
  setGoalMarkers(markers: GoalMarker[]): void {
    const key = JSON.stringify(markers);
    if (key === this.goalsKey) return;
    this.goalsKey = key;
    this.invalidate();
    for (const [robot, group] of this.goals) {
      this.scene.remove(group);
      this.removeLabel(`goal/${robot}`);
    }
    this.goals.clear();
    for (const m of markers) {
      const opacity = m.pending ? 0.55 : 1;
      const material = new THREE.MeshBasicMaterial({ color: m.color, transparent: true, opacity, side: THREE.DoubleSide, depthTest: false });
      const ring = new THREE.Mesh(new THREE.RingGeometry(0.3, 0.45, 32), material);
      ring.position.z = 0.05;
      const post = new THREE.Mesh(new THREE.CylinderGeometry(0.04, 0.04, 1.0, 8), material);
      post.rotation.x = Math.PI / 2;
      post.position.z = 0.5;
      const flag = new THREE.Mesh(new THREE.SphereGeometry(0.12, 12, 8), material);
      flag.position.z = 1.0;
      const group = new THREE.Group();
      group.add(ring, post, flag);
      group.renderOrder = 5;
      group.position.set(m.x, m.y, m.z);
      this.scene.add(group);
      this.goals.set(m.robot, group);
      const label = this.setLabel(`goal/${m.robot}`, "goal", m.pending ? `${m.robot} goal?` : `${m.robot} goal`,
        new THREE.Vector3(m.x, m.y, m.z + 1.2));
      label.el.style.borderLeftColor = m.color;
      label.el.classList.toggle("pending", m.pending);
    }
  }
  private goalsKey = "";

  /** A robot body's colour as drawn, "#rrggbb" ("" for no such robot); for tests. */
  robotColor(id: string): string {
    const obj = this.robots.get(id);
    return obj ? "#" + (obj.body.material as THREE.MeshLambertMaterial).color.getHexString() : "";
  }

  /** The colours of an entity's lines as drawn, "#rrggbb" each; for tests. */
  lineColors(id: string): string[] {
    const group = this.entities.get(id);
    if (!group) return [];
    return group.children.filter((c): c is Line2 => c instanceof Line2).map((l) => "#" + l.material.color.getHexString());
  }

  /** The goal markers drawn now, by robot (for tests). */
  goalMarkers(): string[] {
    return [...this.goals.keys()];
  }

  // ---- Labels ---------------------------------------------------------------------------------------------
  private setLabel(key: string, kind: Label["kind"], text: string, anchor: THREE.Vector3): Label {
    let label = this.labels.get(key);
    if (!label) {
      const el = document.createElement("div");
      el.className = `label ${kind}`;
      el.dataset.key = key;
      this.labelLayer.appendChild(el);
      label = { el, kind, anchor: anchor.clone(), text: "", width: 0, height: 0 };
      this.labels.set(key, label);
    }
    label.anchor.copy(anchor);
    if (label.text !== text) {
      label.text = text;
      label.el.textContent = text;
      label.width = label.el.offsetWidth; // measured once per text, not every frame
      label.height = label.el.offsetHeight;
      this.invalidate();
    }
    return label;
  }

  private removeLabel(key: string): void {
    const label = this.labels.get(key);
    if (!label) return;
    label.el.remove();
    this.labels.delete(key);
  }

  /**
   * Places every label over its anchor, robots first, inside the view's width. A label that would cover one
   * already placed is moved up above it (robots, goals) or hidden (places); one behind the camera or off the
   * view is hidden.
   */
  private layoutLabels(): void {
    const w = this.container.clientWidth, h = this.container.clientHeight;
    const placed: { left: number; top: number; right: number; bottom: number }[] = [];
    const overlapping = (l: number, t: number, r: number, b: number) =>
      placed.find((p) => l < p.right + 2 && r > p.left - 2 && t < p.bottom + 2 && b > p.top - 2);
    const order = [...this.labels.entries()].sort((a, b) => kLabelPriority[a[1].kind] - kLabelPriority[b[1].kind]);
    const v = new THREE.Vector3();
    for (const [key, label] of order) {
      v.copy(label.anchor).project(this.camera);
      // Kept inside the view's width: a robot at the edge keeps its whole name on screen.
      const left = Math.max(2, Math.min(((v.x + 1) / 2) * w - label.width / 2, w - label.width - 2));
      let top = ((1 - v.y) / 2) * h - label.height;
      let shown = v.z < 1 && v.x > -1.2 && v.x < 1.2 && v.y > -1.2 && v.y < 1.2;
      if (shown) {
        for (let tries = 0; tries <= placed.length; tries++) {
          const hit = overlapping(left, top, left + label.width, top + label.height);
          if (!hit) break;
          if (label.kind === "place") {
            shown = false;
            break;
          }
          top = hit.top - label.height - 2;
        }
      }
      if (shown) placed.push({ left, top, right: left + label.width, bottom: top + label.height });
      label.el.style.display = shown ? "" : "none";
      if (shown) label.el.style.transform = `translate(${Math.round(left)}px, ${Math.round(top)}px)`;
      label.box = { key, kind: label.kind, text: label.text, shown, left, top, width: label.width, height: label.height };
    }
  }

  /** Every label as last laid out (client pixels relative to the view), for tests. */
  labelBoxes(): LabelBox[] {
    return [...this.labels.values()].map((l) => l.box).filter((b): b is LabelBox => b !== undefined);
  }

  /** The scale bar: a round length (1, 2 or 5 × 10^k m) about 120 px long at the depth of the view's centre. */
  private updateScaleBar(): void {
    const h = this.container.clientHeight;
    const distance = this.camera.position.distanceTo(this.controls.target);
    const metresPerPixel = (2 * distance * Math.tan(THREE.MathUtils.degToRad(this.camera.fov) / 2)) / Math.max(1, h);
    const want = metresPerPixel * 120;
    const power = Math.pow(10, Math.floor(Math.log10(want)));
    const length = [5, 2, 1].map((k) => k * power).find((l) => l <= want) ?? power;
    const bar = this.scaleBar.firstElementChild as HTMLDivElement;
    bar.style.width = `${Math.round(length / metresPerPixel)}px`;
    const text = length >= 1 ? `${length} m` : `${Math.round(length * 100)} cm`;
    const span = this.scaleBar.lastElementChild as HTMLSpanElement;
    if (span.textContent !== text) span.textContent = text;
    this.scaleLengthM = length;
  }
  /** The scale bar's length as last drawn, m. */
  scaleLengthM = 0;

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
    const surface = this.map.pickSurface(this.raycaster, this.ceilingCut);
    if (surface) return { point: surface, surface: true };
    // The floor under the robot's level: the ground plane through groundZ (a goal names x and y; the level is the robot's).
    const plane = new THREE.Plane(new THREE.Vector3(0, 0, 1), -groundZ);
    const point = new THREE.Vector3();
    if (this.raycaster.ray.intersectPlane(plane, point)) return { point };
    return {};
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
   * every 10 m. The floor is rough as a scan's is: patches and single cells one voxel higher (a quarter of
   * it), so that merged faces do not reduce it to a few rectangles.
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
    // Deterministic noise: a hash of the cell, and patches of 5 x 5 cells.
    const hash = (x: number, y: number) => {
      let h = (x * 374761393 + y * 668265263) | 0;
      h = Math.imul(h ^ (h >>> 13), 1274126177);
      return ((h ^ (h >>> 16)) >>> 0) / 4294967296;
    };
    const raised = (x: number, y: number) => hash(Math.floor(x / 5), Math.floor(y / 5) + 7919) < 0.15 || hash(x, y) < 0.1;
    let made = 0;
    for (let j = 0; j < side * side && made < count; j++, made++) {
      const x = j % side, y = Math.floor(j / side);
      add(x, y, raised(x, y) ? 1 : 0);
    }
    for (let k = 0; made < count; k++, made++) {
      const perWall = side * 10; // 500 voxels long, 10 high
      const wall = Math.floor(k / perWall), w = k % perWall;
      add((wall % 10) * 50 + 25, w % side, 1 + Math.floor(w / side) + 10 * Math.floor(wall / 10));
    }
    for (const [id, cubes] of columns) this.setChunk(id, cubes);
    this.map.flush();
    this.focus(50, 50, 0);
  }

}
