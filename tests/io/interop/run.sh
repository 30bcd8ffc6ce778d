#!/usr/bin/env bash
# MCAP interoperability with the official TypeScript library (@mcap/core) under Node.js:
#   1. our writer writes cdff_{none,lz4,zstd}.mcap        (mcap_interop write)
#   2. @mcap/core reads them, protobufjs decodes them       (node interop.mjs check)
#   3. @mcap/core writes node_*.mcap                        (node interop.mjs write)
#   4. our reader reads those                               (mcap_interop check)
# usage: run.sh SOURCE_DIR WORK_DIR MCAP_INTEROP_BINARY
set -euo pipefail
src=$1
work=$2
tool=$3

for cmd in node npm; do
  if ! command -v "$cmd" >/dev/null 2>&1; then
    echo "FAIL: '$cmd' (Node.js) is not installed. This test reads CDFF's MCAP files with the" \
         "official TypeScript reader (@mcap/core) under Node.js. Install it with" \
         "'sudo bash scripts/install-deps.sh' (Debian packages nodejs and npm)." >&2
    exit 1
  fi
done
echo "node $(node --version), npm $(npm --version)"

mkdir -p "$work"
# npm's cache inside the build directory: no dependency on $HOME (CI runs as root, maybe without).
export npm_config_cache="$work/.npm-cache"
cp "$src/package.json" "$src/package-lock.json" "$src/interop.mjs" "$work/"
# The pinned packages are installed into the build directory, once per version of the lock file;
# later runs work offline.
stamp="$work/node_modules/.cdff-lock-sha256"
want=$(sha256sum "$src/package-lock.json" | cut -d' ' -f1)
if [ ! -f "$stamp" ] || [ "$(cat "$stamp")" != "$want" ]; then
  # Without a reachable registry the test cannot run at all: CTest reports it as skipped
  # (exit 77), loudly, rather than failing the suite for a network outage. Set
  # CDFF_REQUIRE_INTEROP=1 to make that a failure.
  if ! npm ping --loglevel=error > /dev/null 2>&1; then
    echo "SKIPPED: the npm registry ($(npm config get registry)) is unreachable, so @mcap/core" \
         "cannot be installed; the interoperability test did not run" >&2
    [ "${CDFF_REQUIRE_INTEROP:-0}" = 1 ] && exit 1
    exit 77
  fi
  if ! (cd "$work" && npm ci --ignore-scripts --no-audit --no-fund --loglevel=error); then
    echo "FAIL: 'npm ci' could not install the pinned packages of $src/package-lock.json" \
         "(the npm registry must be reachable for the first run)" >&2
    exit 1
  fi
  echo "$want" > "$stamp"
fi

data="$work/files"
rm -rf "$data"
mkdir -p "$data"
"$tool" write "$data"
(cd "$work" && node interop.mjs check "$data")
(cd "$work" && node interop.mjs write "$data")
"$tool" check "$data"
echo "interoperability with @mcap/core: ok"
