// Runs the Khronos glTF-Validator on one .glb or .gltf (external .bin resolved beside it)
// and prints the full report as JSON on stdout.
//
//   BEESWARM_NODE_MODULES=/path/to/node_modules node tests/node/validate_gltf.mjs FILE
//
// The validator package is located through BEESWARM_NODE_MODULES (ES modules ignore
// NODE_PATH), falling back to ordinary resolution. Exit code: 0 when a report was
// produced (the caller judges its issues), 2 when the file could not be validated at all.
import { createRequire } from 'node:module';
import fs from 'node:fs';
import path from 'node:path';

const require = createRequire(import.meta.url);
const modules = process.env.BEESWARM_NODE_MODULES;
const validator = require(modules ? path.join(modules, 'gltf-validator') : 'gltf-validator');

const file = process.argv[2];
if (!file) {
  console.error('usage: validate_gltf.mjs FILE.glb|FILE.gltf');
  process.exit(2);
}

try {
  const bytes = new Uint8Array(fs.readFileSync(file));
  const report = await validator.validateBytes(bytes, {
    uri: path.basename(file),
    maxIssues: 1000,
    externalResourceFunction: async (uri) =>
      new Uint8Array(await fs.promises.readFile(path.resolve(path.dirname(file), decodeURIComponent(uri)))),
  });
  process.stdout.write(JSON.stringify(report, null, 1) + '\n');
} catch (e) {
  console.error(`cannot validate ${file}: ${e}`);
  process.exit(2);
}
