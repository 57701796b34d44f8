// Bundle the dashboard into web/dist: esbuild (ESM + code splitting, so three.js loads only with the viewer).
import { build } from "esbuild";
import { copyFileSync, mkdirSync, rmSync, statSync, readdirSync } from "node:fs";
import { basename, dirname, join } from "node:path";
import { fileURLToPath } from "node:url";

const web = dirname(fileURLToPath(import.meta.url));
const dist = join(web, "dist");
rmSync(dist, { recursive: true, force: true });
mkdirSync(dist, { recursive: true });

await build({
  entryPoints: [join(web, "src/main.ts")],
  bundle: true,
  splitting: true,
  format: "esm",
  minify: true,
  sourcemap: false,
  target: ["chrome110", "firefox115", "safari16"],
  outdir: join(dist, "assets"),
  entryNames: "[name]",
  chunkNames: "chunk-[hash]",
  legalComments: "linked",
  logLevel: "warning",
});
for (const file of ["index.html", "style.css"]) copyFileSync(join(web, file), join(dist, file));

// The API docs pages (/docs, /redoc) load Swagger UI and ReDoc from here, never from a CDN (api/docs_pages.py).
const modules = join(web, "..", "node_modules");
const docsAssets = {
  "swagger-ui": ["swagger-ui-dist", ["swagger-ui-bundle.js", "swagger-ui.css", "favicon-32x32.png", "LICENSE"]],
  "redoc": ["redoc", ["bundles/redoc.standalone.js", "bundles/redoc.standalone.js.LICENSE.txt", "LICENSE"]],
};
for (const [name, [pkg, files]] of Object.entries(docsAssets)) {
  mkdirSync(join(dist, "docs-assets", name), { recursive: true });
  for (const file of files) copyFileSync(join(modules, pkg, file), join(dist, "docs-assets", name, basename(file)));
}

const sizes = readdirSync(join(dist, "assets"))
  .filter((f) => f.endsWith(".js"))
  .map((f) => [f, statSync(join(dist, "assets", f)).size]);
const total = sizes.reduce((a, [, s]) => a + s, 0);
console.log(`web/dist: ${sizes.length} JS files, ${(total / 1024).toFixed(0)} KiB (${sizes.map(([f, s]) => `${f} ${(s / 1024).toFixed(0)} KiB`).join(", ")})`);
