#!/usr/bin/env bash
# Install the named Debian packages when any is missing (offscreen GL for rendering, chromium for the
# viewer's browser tests, LLVM for the photo preset). Waits for a busy apt lock instead of failing.
set -euo pipefail
missing=()
for pkg in "$@"; do
  dpkg-query -W -f='${Status}' "$pkg" 2>/dev/null | grep -q "install ok installed" || missing+=("$pkg")
done
[ ${#missing[@]} -eq 0 ] && exit 0
if ! command -v apt-get >/dev/null 2>&1; then
  echo "samplehd: Debian packages missing (${missing[*]}) and apt-get is not available; install them by hand" >&2
  exit 1
fi
sudo=""
[ "$(id -u)" -ne 0 ] && sudo="sudo"
echo "samplehd: installing Debian packages: ${missing[*]}"
export DEBIAN_FRONTEND=noninteractive
lock=(-o DPkg::Lock::Timeout=300)
for attempt in 1 2 3; do
  if $sudo apt-get "${lock[@]}" update -qq </dev/null && \
     $sudo apt-get "${lock[@]}" install -y -qq --no-install-recommends "${missing[@]}" </dev/null >/dev/null; then
    exit 0
  fi
  echo "samplehd: apt-get failed (attempt $attempt); retrying in 20 s" >&2
  sleep 20
done
exit 1
