#!/usr/bin/env bash
# Re-makes contracts/build/SwarmFL.json (ABI + creation bytecode) from SwarmFL.sol with the npm
# `solc` package at the pinned version, or with --check verifies that the committed artefact is
# what the source compiles to. Building swarmfl needs no Node: the artefact is committed.
#
#   contracts/build.sh            # compile and write build/SwarmFL.json
#   contracts/build.sh --check    # compile and compare with the committed file
#
# The compiler is installed once in a scratch directory outside the repository
# (SOLC_TOOLS, default ../solc-tools next to the clone): never commit node_modules.
set -euo pipefail
SOLC_VERSION=0.8.30
here="$(cd "$(dirname "$0")" && pwd)"
tools="${SOLC_TOOLS:-$here/../../solc-tools}"
if [ ! -f "$tools/node_modules/solc/package.json" ] \
   || [ "$(node -p "require('$tools/node_modules/solc/package.json').version")" != "$SOLC_VERSION" ]; then
  mkdir -p "$tools"
  (cd "$tools" && npm init -y >/dev/null && npm install --no-audit --no-fund "solc@$SOLC_VERSION" >/dev/null)
fi
fresh="$(mktemp)"
trap 'rm -f "$fresh"' EXIT
NODE_PATH="$tools/node_modules" node "$here/compile.js" "$here/SwarmFL.sol" > "$fresh"
if [ "${1:-}" = "--check" ]; then
  if cmp -s "$fresh" "$here/build/SwarmFL.json"; then
    echo "contracts/build/SwarmFL.json matches SwarmFL.sol (solc $SOLC_VERSION)"
  else
    echo "contracts/build/SwarmFL.json is stale: run contracts/build.sh and commit it" >&2
    exit 1
  fi
else
  mkdir -p "$here/build"
  cp "$fresh" "$here/build/SwarmFL.json"
  echo "wrote contracts/build/SwarmFL.json (solc $SOLC_VERSION)"
fi
