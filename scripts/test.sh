#!/usr/bin/env bash
# The whole test suite on a fresh machine: installs what the tests need when it is missing,
# then runs every test. GLOBE_REQUIRE_GPU=1 and GLOBE_REQUIRE_DATA=1 make the rendering and
# real-data tests fail rather than skip when their adapter or data is missing.
set -euo pipefail
cd "$(dirname "$0")/.."

have_vulkan() {
    # No early-exiting pipes here: under pipefail a SIGPIPE would read as "missing".
    local loader icd
    loader=$(ldconfig -p 2>/dev/null | grep -c 'libvulkan\.so\.1' || true)
    icd=$(find /usr/share/vulkan/icd.d /etc/vulkan/icd.d -name '*.json' 2>/dev/null || true)
    [ "${loader:-0}" -gt 0 ] && [ -n "$icd" ]
}

# What the tests need that a fresh machine lacks: a Vulkan driver (Mesa's software one,
# lavapipe), GDAL's command-line tools (an independent EHdr reader to cross-check against) and
# Debian's ferret-datasets (ETOPO5, the real Earth the embedded model comes from), and nginx
# (tests/formats/remote.rs serves a pyramid with range requests; run as this user from a temp dir).
packages=()
if ! have_vulkan; then packages+=(mesa-vulkan-drivers libvulkan1); fi
if ! command -v gdallocationinfo >/dev/null; then packages+=(gdal-bin); fi
if [ ! -f /usr/share/ferret-vis/data/etopo5.cdf ]; then packages+=(ferret-datasets); fi
if [ ! -x /usr/sbin/nginx ] && ! command -v nginx >/dev/null; then packages+=(nginx); fi
if [ ${#packages[@]} -gt 0 ]; then
    echo "scripts/test.sh: installing ${packages[*]}" >&2
    if ! command -v apt-get >/dev/null; then
        echo "scripts/test.sh: apt-get not available; install ${packages[*]} (or their equivalents)" >&2
        exit 1
    fi
    sudo=""
    if [ "$(id -u)" -ne 0 ]; then sudo="sudo"; fi
    $sudo apt-get update -qq
    DEBIAN_FRONTEND=noninteractive $sudo apt-get install -y -qq --no-install-recommends "${packages[@]}" >/dev/null
fi

# The map-transform reference vectors are reproduced from scratch in 60-digit arithmetic.
if ! python3 -c 'import mpmath' 2>/dev/null; then
    echo "scripts/test.sh: installing mpmath (pip)" >&2
    python3 -m pip install --quiet mpmath || python3 -m pip install --quiet --break-system-packages mpmath
fi
python3 scripts/map_transform_vectors.py --check tests/data/map_transform_vectors.csv

# The S3-compatible server of tests/formats/remote.rs: moto's server (pure Python wheels, seconds to
# install, nothing to compile; boto3 comes with it and uploads the test object).
if ! python3 -c 'import moto.server, boto3' 2>/dev/null; then
    echo "scripts/test.sh: installing moto[server] (pip)" >&2
    python3 -m pip install --quiet 'moto[server]' || python3 -m pip install --quiet --break-system-packages 'moto[server]'
fi

export GLOBE_REQUIRE_GPU=1
export GLOBE_REQUIRE_DATA=1
# Mesa's device-select layer probes the display (and complains when this is unset) for GPU tests
# that create their instance in-process; the `globe` binary switches that layer off itself.
export XDG_RUNTIME_DIR="${XDG_RUNTIME_DIR:-$(mktemp -d)}"
if [ $# -gt 0 ]; then
    cargo test --workspace "$@"
    exit
fi

# Every test binary built first (one cargo build), then the rendering tests in the background
# beside the others: their GPU work is serialised (tests/common) and leaves about a third of
# the second core idle (a software rasteriser and the reference ray cast in turn), which the
# CPU, format and command-line tests fill. The rendering tests run one at a time, as when each
# had its own binary; their output is printed whole when they end.
suites=(--workspace --lib --bins --test cpu --test formats --test cli --test fuzz --test globe_data)
cargo test "${suites[@]}" --test gpu --no-run
gpu_log=$(mktemp)
(
    cargo test --test gpu -- --test-threads=1
    # The GPU-against-f64 tests once more with every builtin sin/cos as coarse as an NVIDIA
    # GPU's (shaders/common/trig.wgsl says why): a software adapter's builtins are exact to
    # rounding, so only this shows code that a real GPU would break.
    GLOBE_COARSE_TRIG=1 cargo test --test gpu -- gpu_detail:: gpu_normals:: gpu_transform::
) >"$gpu_log" 2>&1 &
gpu_pid=$!
status=0
cargo test "${suites[@]}" || status=$?
cargo test --workspace --doc || status=$?
gpu_status=0
wait "$gpu_pid" || gpu_status=$?
echo "scripts/test.sh: the rendering tests (tests/gpu), run beside the others:"
cat "$gpu_log"
rm -f "$gpu_log"
if [ "$gpu_status" -ne 0 ]; then
    echo "scripts/test.sh: the rendering tests failed" >&2
    status=$gpu_status
fi
exit "$status"
