// Validate a .gltf (and the files it references) with Khronos' glTF-Validator (npm gltf-validator):
// node gltf_validate.js <gltf-validator module folder> <file.gltf>; prints the JSON report
// (tests/test_material_sets.py).
const fs = require("fs");
const path = require("path");
const validator = require(process.argv[2]);
const file = process.argv[3];
validator.validateBytes(new Uint8Array(fs.readFileSync(file)), {
  uri: path.basename(file),
  externalResourceFunction: (uri) => new Promise((resolve, reject) => {
    fs.readFile(path.join(path.dirname(file), decodeURIComponent(uri)), (err, data) => err ? reject(err.toString()) : resolve(new Uint8Array(data)));
  }),
}).then((report) => console.log(JSON.stringify(report))).catch((e) => { console.error(e); process.exit(2); });
