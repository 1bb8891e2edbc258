#!/usr/bin/env bash
# Installs the Debian packages tonegate's jobs need, when they are missing.
# Sourced by ci/main.sh and ci/test.sh; idempotent, and quiet when all is there.
#   mesa-vulkan-drivers - lavapipe, the software Vulkan driver the GPU pipeline runs on
#   pfstools, pfstmo   - the peer tone mapper the reinhard02 preset is locked to
#   python3-venv       - the scikit-image venv that regenerates tests/skimage/vectors.json
#   chromium           - the real browser the dashboard tests (tests/it/dashboard.rs) drive
#   postgresql         - the real server the shared-history tests (tests/it/postgres.rs) start
#   vulkan-validationlayers - the Khronos layer the adapter tests (tests/it/adapters.rs) run the gate under
#   libegl1, libegl-mesa0, libgl1-mesa-dri - Mesa's EGL and llvmpipe for wgpu's GL backend
#   nodejs, npm        - run three.js's and glsl-tone-map's shader text for tests/operators/vectors.json
#   libplacebo-dev, pkg-config, gcc - build the C harness that writes tests/bt2390/vectors.json
#   (chromium also ships SwiftShader, the second Vulkan implementation the gate runs on)
set -euo pipefail

need=()
ls /usr/share/vulkan/icd.d/lvp_icd*.json >/dev/null 2>&1 || need+=(mesa-vulkan-drivers)
command -v pfstmo_reinhard02 >/dev/null 2>&1 || need+=(pfstools pfstmo)
python3 -c 'import ensurepip, venv' >/dev/null 2>&1 || need+=(python3-venv)
command -v chromium >/dev/null 2>&1 || command -v chromium-browser >/dev/null 2>&1 || need+=(chromium)
ls /usr/lib/postgresql/*/bin/initdb >/dev/null 2>&1 || need+=(postgresql)
ls /usr/share/vulkan/explicit_layer.d/VkLayer_khronos_validation.json >/dev/null 2>&1 || need+=(vulkan-validationlayers)
ls /usr/lib/*/libEGL.so.1 /usr/lib/*/libEGL_mesa.so.0 >/dev/null 2>&1 || need+=(libegl1 libegl-mesa0)
ls /usr/lib/*/dri/swrast_dri.so >/dev/null 2>&1 || need+=(libgl1-mesa-dri)
# By command, not package: a machine with another node (and its own npm)
# keeps it.
command -v node >/dev/null 2>&1 || need+=(nodejs)
command -v npm >/dev/null 2>&1 || need+=(npm)
command -v pkg-config >/dev/null 2>&1 || need+=(pkg-config)
{ command -v pkg-config >/dev/null 2>&1 && pkg-config --exists libplacebo; } || need+=(libplacebo-dev)
command -v cc >/dev/null 2>&1 || need+=(gcc)
if [ "${#need[@]}" -gt 0 ]; then
  sudo=""
  [ "$(id -u)" -eq 0 ] || sudo="sudo"
  echo "installing: ${need[*]}"
  $sudo apt-get update -qq
  DEBIAN_FRONTEND=noninteractive $sudo apt-get install -y -qq "${need[@]}" >/dev/null
fi
