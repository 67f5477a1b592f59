#!/usr/bin/env bash
# The whole test suite on a fresh machine: installs a software Vulkan driver (Mesa lavapipe)
# when no Vulkan driver is present, then runs every test. GLOBE_REQUIRE_GPU=1 makes the
# rendering tests fail rather than skip if no adapter can be opened.
set -euo pipefail
cd "$(dirname "$0")/.."

have_vulkan() {
    # No early-exiting pipes here: under pipefail a SIGPIPE would read as "missing".
    local loader icd
    loader=$(ldconfig -p 2>/dev/null | grep -c 'libvulkan\.so\.1' || true)
    icd=$(find /usr/share/vulkan/icd.d /etc/vulkan/icd.d -name '*.json' 2>/dev/null || true)
    [ "${loader:-0}" -gt 0 ] && [ -n "$icd" ]
}

if ! have_vulkan; then
    echo "scripts/test.sh: no Vulkan driver found; installing Mesa's software driver (lavapipe)" >&2
    if ! command -v apt-get >/dev/null; then
        echo "scripts/test.sh: apt-get not available; install a Vulkan driver (e.g. Mesa lavapipe) and the Vulkan loader" >&2
        exit 1
    fi
    sudo=""
    if [ "$(id -u)" -ne 0 ]; then sudo="sudo"; fi
    $sudo apt-get update -qq
    DEBIAN_FRONTEND=noninteractive $sudo apt-get install -y -qq mesa-vulkan-drivers libvulkan1 >/dev/null
fi

export GLOBE_REQUIRE_GPU=1
# Mesa's window-system layer complains when this is unset; the tests never open a window.
export XDG_RUNTIME_DIR="${XDG_RUNTIME_DIR:-$(mktemp -d)}"
cargo test --workspace "$@"
