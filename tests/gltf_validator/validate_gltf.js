// validate_gltf.js -- runs the Khronos glTF validator (the npm package gltf-validator, fetched by
// scripts/setup.sh into DATA/npm/gltf-validator) on glTF / GLB files, for the tests.
//   node validate_gltf.js VALIDATOR_DIR FILE...
// Prints one line per file ("FILE: E errors, W warnings, I infos") and one line per error and
// warning ("  error CODE POINTER: MESSAGE"). External resources (buffers, images) are read
// relative to each file, as a viewer would. Exit status: 0 when no file has an error, 1 when
// one has, 2 on a usage error or a file or validator that cannot be read.
'use strict';
const fs = require('fs');
const path = require('path');

async function main(argv) {
  if (argv.length < 2) {
    process.stderr.write('usage: node validate_gltf.js VALIDATOR_DIR FILE...\n');
    return 2;
  }
  let validator;
  try {
    validator = require(path.resolve(argv[0]));
  } catch (e) {
    process.stderr.write(`cannot load the glTF validator from ${argv[0]}: ${e.message} (run scripts/setup.sh)\n`);
    return 2;
  }
  const severities = ['error', 'warning', 'info', 'hint'];
  let failed = false;
  for (const file of argv.slice(1)) {
    let bytes;
    try {
      bytes = new Uint8Array(fs.readFileSync(file));
    } catch (e) {
      process.stderr.write(`cannot read ${file}: ${e.message}\n`);
      return 2;
    }
    const dir = path.dirname(file);
    const report = await validator.validateBytes(bytes, {
      uri: path.basename(file),
      maxIssues: 1000,
      externalResourceFunction: (uri) =>
        new Promise((resolve, reject) => {
          fs.readFile(path.join(dir, decodeURIComponent(uri)), (err, data) =>
            err ? reject(err.toString()) : resolve(new Uint8Array(data)));
        }),
    });
    const issues = report.issues;
    process.stdout.write(`${file}: ${issues.numErrors} errors, ${issues.numWarnings} warnings, ${issues.numInfos} infos\n`);
    for (const m of issues.messages)
      if (m.severity <= 1)
        process.stdout.write(`  ${severities[m.severity]} ${m.code} ${m.pointer || ''}: ${m.message}\n`);
    if (issues.numErrors > 0) failed = true;
  }
  return failed ? 1 : 0;
}

main(process.argv.slice(2)).then((code) => { process.exitCode = code; }, (e) => {
  process.stderr.write(`glTF validator failed: ${e && e.stack ? e.stack : e}\n`);
  process.exitCode = 2;
});
