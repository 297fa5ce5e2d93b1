#!/usr/bin/env bash
# Installs the Debian packages listed in deploy/debian-packages.txt that are missing.
# Idempotent and quick when everything is present: it only asks dpkg, and runs apt-get (update
# and install) only when something is missing.
set -euo pipefail
here=$(cd "$(dirname "$0")" && pwd)
mapfile -t wanted < <(grep -Ev '^\s*(#|$)' "$here/debian-packages.txt")

missing=()
for pkg in "${wanted[@]}"; do
  # A machine whose Node.js comes from elsewhere (NodeSource's nodejs includes npm and conflicts
  # with Debian's npm package) keeps its own.
  if [ "$pkg" = npm ] && command -v npm >/dev/null; then continue; fi
  status=$(dpkg-query -W -f='${db:Status-Status}' "$pkg" 2>/dev/null || true)
  [ "$status" = "installed" ] || missing+=("$pkg")
done
install_npm() {
  # The browser client's npm packages, exactly as client/web/package-lock.json pins them; again
  # only when the lockfile changed since the last install (a copy of it is kept as the stamp).
  local web="$here/../client/web"
  if ! cmp -s "$web/package-lock.json" "$web/node_modules/.arlight-package-lock.json" 2>/dev/null; then
    echo "deps: npm ci in client/web (playwright-core, opencv.js, three, ktx-parse, gltf-validator)"
    (cd "$web" && npm ci --no-audit --no-fund --loglevel=error)
    cp "$web/package-lock.json" "$web/node_modules/.arlight-package-lock.json"
  fi
}

if [ ${#missing[@]} -eq 0 ]; then
  echo "deps: all ${#wanted[@]} Debian packages present"
  install_npm
  exit 0
fi

echo "deps: installing ${#missing[@]} missing Debian packages: ${missing[*]}"
sudo=""
if [ "$(id -u)" -ne 0 ]; then
  command -v sudo >/dev/null || { echo "deps: not root and no sudo; install as root: apt-get install ${missing[*]}" >&2; exit 1; }
  sudo="sudo"
fi
export DEBIAN_FRONTEND=noninteractive
$sudo apt-get update -q
$sudo apt-get install -y -q --no-install-recommends "${missing[@]}"
install_npm
