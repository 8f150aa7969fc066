#!/usr/bin/env bash
# The Blender add-on's end-to-end test (tools/blender_addon_check.py): builds the add-on's zip,
# installs it into a private Blender user folder and bakes, compares, interrupts and resumes
# scenes with the wetcloth command the workspace builds (target/release/wetcloth, under
# $CARGO_TARGET_DIR when set, or $WETCLOTH_BIN). Skips when Blender is missing, and fails then
# with WETCLOTH_REQUIRE_TOOLS=1. About 15 s on a 2-core machine.
set -euo pipefail
cd "$(dirname "$0")/.."
bin="${WETCLOTH_BIN:-${CARGO_TARGET_DIR:-target}/release/wetcloth}"
if ! command -v blender >/dev/null 2>&1; then
  if [ "${WETCLOTH_REQUIRE_TOOLS:-}" = 1 ]; then
    echo "test-blender: \`blender\` is not installed (apt-get install blender), and WETCLOTH_REQUIRE_TOOLS=1" >&2
    exit 1
  fi
  echo "test-blender: skipped, \`blender\` is not installed (apt-get install blender)"
  exit 0
fi
if [ ! -x "$bin" ]; then
  echo "test-blender: no wetcloth command at $bin (cargo build --release -p wetcloth-cli, or set WETCLOTH_BIN)" >&2
  exit 1
fi
bin="$(cd "$(dirname "$bin")" && pwd)/$(basename "$bin")"
work="$(mktemp -d "${TMPDIR:-/tmp}/wetcloth-blender.XXXXXX")"
trap 'rm -rf "$work"' EXIT
tools/make-blender-zip.sh "$work/wetcloth_blender.zip" >/dev/null
start=$(date +%s)
# A private user folder: the add-on is installed there, not into the user's own Blender.
BLENDER_USER_SCRIPTS="$work/user/scripts" BLENDER_USER_CONFIG="$work/user/config" \
BLENDER_USER_EXTENSIONS="$work/user/extensions" \
  blender -b --factory-startup --python-exit-code 1 --python tools/blender_addon_check.py -- \
    --zip "$work/wetcloth_blender.zip" --wetcloth "$bin" --work "$work/check" 2>&1 |
  grep -v -e '^$' -e '^Blender quit' -e '^Read prefs' -e '^Warning: Permission' -e '^Info: Saved' -e '^Saved "' -e '^Read blend'
status=${PIPESTATUS[0]}
echo "test-blender: $(( $(date +%s) - start )) s"
exit "$status"
