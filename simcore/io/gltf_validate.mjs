// Khronos glTF validator runner: node gltf_validate.mjs VALIDATOR_PACKAGE_DIR FILE...
// Prints one JSON array with the validator's report for each file, in argument order.
// External resources are refused: RigForge only writes self-contained GLB/.gltf files.
import { readFile } from "node:fs/promises";
import { createRequire } from "node:module";
import path from "node:path";

const [packageDir, ...files] = process.argv.slice(2);
const require = createRequire(path.join(path.resolve(packageDir), "package.json"));
const validator = require(path.resolve(packageDir));

const reports = [];
for (const file of files) {
  const bytes = new Uint8Array(await readFile(file));
  try {
    reports.push(await validator.validateBytes(bytes, {
      uri: path.basename(file),
      maxIssues: 200,
      externalResourceFunction: (uri) => Promise.reject(`external resource ${uri} refused`),
    }));
  } catch (error) {
    // Rejection means the bytes are not recognisable glTF at all; report it as one error.
    reports.push({ uri: path.basename(file), fatal: String(error),
                   issues: { numErrors: 1, numWarnings: 0, numInfos: 0, numHints: 0, messages: [] } });
  }
}
process.stdout.write(JSON.stringify(reports));
