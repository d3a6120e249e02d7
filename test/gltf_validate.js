// Copyright 2026 jacket_cloth_ros maintainers. Licensed under the Apache License, Version 2.0.
// The Khronos glTF validator (npm gltf-validator) on each file named: one JSON line per file
// with its counts of errors, warnings, infos and hints, and its errors' and warnings' messages.
// Usage: NODE_PATH=.venv/node/node_modules node test/gltf_validate.js FILE...
'use strict';
const fs = require('fs');
const validator = require('gltf-validator');

async function main(files) {
    for (const file of files) {
        const report = await validator.validateBytes(new Uint8Array(fs.readFileSync(file)), {
            uri: file, maxIssues: 0,
        });
        const issues = report.issues;
        console.log(JSON.stringify({
            file: file, version: report.validatorVersion,
            errors: issues.numErrors, warnings: issues.numWarnings,
            infos: issues.numInfos, hints: issues.numHints,
            messages: issues.messages.filter((m) => m.severity <= 1).slice(0, 20),
        }));
    }
}

main(process.argv.slice(2)).catch((e) => {
    console.error(String(e));
    process.exit(1);
});
