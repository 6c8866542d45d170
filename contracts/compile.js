// Compiles SwarmFL.sol with the npm `solc` package (pinned in build.sh) and prints
// {"abi": ..., "bytecode": "0x..."} as JSON on stdout. Usage: node compile.js SOURCE.sol
const fs = require("fs");
const path = require("path");
const solc = require("solc");

const file = process.argv[2];
const input = {
  language: "Solidity",
  sources: { [path.basename(file)]: { content: fs.readFileSync(file, "utf8") } },
  settings: {
    optimizer: { enabled: true, runs: 200 },
    viaIR: true,
    evmVersion: "prague",
    metadata: { bytecodeHash: "none", appendCBOR: false },
    outputSelection: { "*": { "*": ["abi", "evm.bytecode.object"] } },
  },
};
const out = JSON.parse(solc.compile(JSON.stringify(input)));
const errors = (out.errors || []).filter((e) => e.severity === "error");
for (const e of out.errors || []) process.stderr.write(e.formattedMessage + "\n");
if (errors.length > 0) process.exit(1);
const contracts = out.contracts[path.basename(file)];
const name = Object.keys(contracts)[0];
process.stdout.write(
  JSON.stringify({
    compiler: solc.version(),
    contract: name,
    abi: contracts[name].abi,
    bytecode: "0x" + contracts[name].evm.bytecode.object,
  }) + "\n"
);
