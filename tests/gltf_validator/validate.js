// Validates glTF/GLB files with the Khronos glTF validator (npm package gltf-validator) and
// prints one JSON report per file as a JSON array on stdout: the validator's own report
// (issues.numErrors, numWarnings, numInfos, numHints, messages, info) with "uri" the path.
// Degenerate triangles (information by default) and non-object extras are raised to errors:
// dsmplan's GLBs must have neither. Usage: node validate.js FILE...; exit 0 when every file
// was validated (whatever the issues), 2 when one could not be read or parsed at all.
'use strict';
const fs = require('fs');
const validator = require('gltf-validator');

const ERROR = 0;
const options = {
  maxIssues: 0,  // all of them
  writeTimestamp: false,
  severityOverrides: {ACCESSOR_INDEX_TRIANGLE_DEGENERATE: ERROR, NON_OBJECT_EXTRAS: ERROR},
};

async function main(files) {
  if (files.length === 0) {
    console.error('usage: node validate.js FILE...');
    return 2;
  }
  const reports = [];
  for (const file of files) {
    const bytes = new Uint8Array(fs.readFileSync(file));
    reports.push(await validator.validateBytes(bytes, {...options, uri: file}));
  }
  process.stdout.write(JSON.stringify(reports, null, 1) + '\n');
  return 0;
}

main(process.argv.slice(2)).then(
    (code) => { process.exitCode = code; },
    (error) => { console.error('validate.js: ' + error); process.exitCode = 2; });
