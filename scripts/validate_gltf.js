// Validates glTF files with the Khronos glTF-Validator (npm package gltf-validator, installed
// by `make setup`) and prints one JSON report per file: {file, numErrors, numWarnings, messages}.
// Exit status 1 if a file has errors or cannot be read.
//
//   node scripts/validate_gltf.js FILE.glb...
const fs = require("fs");
const validator = require("gltf-validator");

async function main(files) {
  let failed = false;
  for (const file of files) {
    try {
      const report = await validator.validateBytes(new Uint8Array(fs.readFileSync(file)));
      const { numErrors, numWarnings, messages } = report.issues;
      console.log(JSON.stringify({ file, numErrors, numWarnings, messages }));
      failed = failed || numErrors > 0;
    } catch (error) {
      console.log(JSON.stringify({ file, error: String(error) }));
      failed = true;
    }
  }
  process.exit(failed ? 1 : 0);
}

main(process.argv.slice(2));
