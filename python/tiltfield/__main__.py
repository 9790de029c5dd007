"""``python -m tiltfield``: prints the version and the Vulkan device the module renders on
(a smoke test of a new install: it loads the native module and starts Vulkan)."""

import sys

import tiltfield


def main() -> int:
    try:
        d = tiltfield.device()
    except RuntimeError as e:
        print(f"tiltfield {tiltfield.__version__}: no usable Vulkan device: {e}", file=sys.stderr)
        return 1
    print(f"tiltfield {tiltfield.__version__}")
    print(f"device: {d['name']} ({d['kind']}, Vulkan {d['api_version']}, driver {d['driver']})")
    return 0


if __name__ == "__main__":
    sys.exit(main())
