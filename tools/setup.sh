#!/usr/bin/env bash
# Installs what tiltfield needs on Debian 12 and is missing; safe to run any number of times.
#   Vulkan: loader, lavapipe (software driver), validation layers, vulkaninfo
#   Build:  shaderc, glslang and SPIRV-Tools as static libraries (libshaderc-dev, glslang-dev,
#           spirv-tools: the shaders compile against the system's shaderc, no 20-minute source
#           build; glslc, the same compiler's command line, checks every shader in the tests);
#           cmake, python3, a C++ compiler and pkg-config (GLFW's bundled build, and shaderc's
#           from-source fallback on systems without those packages)
#   Window: X11 headers for GLFW's bundled build, xvfb for headless window tests
#   Python: venv and headers for the Python module (tools/test.sh builds it into a virtual
#           environment; pyo3 needs the interpreter's headers and `python3 -m venv`); mypy,
#           which checks the module's type stubs (tests/python/test_types.py)
#   Video:  ffmpeg (`tiltfield animate -o OUT.mp4` pipes its frames to it for H.264; its tests
#           count the frames with ffprobe, which comes with it)
# Needs root or sudo for apt-get; installs Rust with rustup only if cargo is missing.
set -euo pipefail

packages=(
  mesa-vulkan-drivers libvulkan1 libvulkan-dev vulkan-validationlayers vulkan-tools
  libshaderc-dev glslang-dev spirv-tools glslc
  cmake python3 python3-venv python3-dev python3-mypy g++ pkg-config
  libx11-dev libxrandr-dev libxinerama-dev libxcursor-dev libxi-dev libxkbcommon-dev xvfb
  ffmpeg
)

missing=()
for p in "${packages[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done

if ((${#missing[@]})); then
  echo "setup: installing ${missing[*]}" >&2
  sudo=""
  if [ "$(id -u)" -ne 0 ]; then
    command -v sudo >/dev/null || { echo "setup: need root or sudo to install packages" >&2; exit 1; }
    sudo="sudo"
  fi
  $sudo apt-get update -qq
  DEBIAN_FRONTEND=noninteractive $sudo apt-get install -y -qq --no-install-recommends "${missing[@]}" >&2
fi

if ! command -v cargo >/dev/null; then
  [ -x "$HOME/.cargo/bin/cargo" ] || {
    echo "setup: installing Rust with rustup" >&2
    command -v curl >/dev/null || { echo "setup: need curl to install Rust" >&2; exit 1; }
    curl -sSf https://sh.rustup.rs | sh -s -- -y --profile minimal -c clippy,rustfmt >&2
  }
fi
echo "setup: dependencies present" >&2
