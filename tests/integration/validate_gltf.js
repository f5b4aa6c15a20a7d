// Validates .glb/.gltf files with the Khronos glTF Validator (npm: gltf-validator).
// usage: node validate_gltf.js FILE...   exit 0 when every file has 0 errors.
const fs = require('fs');
const validator = require('gltf-validator');
(async () => {
  let bad = 0;
  for (const f of process.argv.slice(2)) {
    const r = await validator.validateBytes(new Uint8Array(fs.readFileSync(f)), {maxIssues: 100});
    const errors = r.issues.messages.filter((m) => m.severity === 0);
    console.log(`${f}: ${r.issues.numErrors} errors, ${r.issues.numWarnings} warnings`);
    for (const m of errors.slice(0, 10)) console.log(`  ${m.code} ${m.pointer || ''} ${m.message}`);
    if (r.issues.numErrors) bad = 1;
  }
  process.exit(bad);
})().catch((e) => { console.error(e); process.exit(2); });
