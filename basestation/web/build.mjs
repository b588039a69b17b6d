// Builds the operator GUI into OUT_DIR (default ./dist): app.js (esbuild bundle of src/main.ts with three.js
// and @foxglove/ws-protocol), wire.mjs, voxel_mesh.mjs and health.mjs (src/wire.ts, src/voxel_mesh.ts and src/health.ts for the tests), index.html, style.css, and foxglove-schemas.json (Foxglove's JSON schemas of the
// well-known messages cairn_base advertises, from @foxglove/schemas). Run by ./cairn build through CMake.
import { build } from "esbuild";
import { copyFileSync, mkdirSync, writeFileSync } from "node:fs";
import { dirname, join, resolve } from "node:path";
import { fileURLToPath } from "node:url";
import { createRequire } from "node:module";
const schemas = createRequire(import.meta.url)("@foxglove/schemas/jsonschema");

const here = dirname(fileURLToPath(import.meta.url));
const out = resolve(process.argv[2] ?? join(here, "dist"));
mkdirSync(out, { recursive: true });
await build({
  entryPoints: [join(here, "src/main.ts")],
  bundle: true,
  format: "iife",
  target: "es2020",
  minify: true,
  sourcemap: true,
  outfile: join(out, "app.js"),
  logLevel: "warning",
});
// The wire module (test/harness.mjs loadWire), the voxel mesher and the health rules alone, as ES modules for
// the tests.
for (const module of ["wire", "voxel_mesh", "health"]) {
  await build({
    entryPoints: [join(here, `src/${module}.ts`)],
    bundle: true,
    format: "esm",
    target: "es2020",
    outfile: join(out, `${module}.mjs`),
    logLevel: "warning",
  });
}
for (const f of ["index.html", "style.css", "favicon.svg"]) copyFileSync(join(here, f), join(out, f));
const wanted = ["SceneUpdate", "FrameTransforms", "CompressedImage", "Log", "PointCloud"];
const table = Object.fromEntries(wanted.map((name) => [`foxglove.${name}`, schemas[name]]));
writeFileSync(join(out, "foxglove-schemas.json"), JSON.stringify(table));
console.log(`web app built into ${out}`);
