"""Print the value of ``NPY_DISABLE_CPU_FEATURES`` that turns off every SIMD extension
NumPy dispatches to at run time on this machine (x86-64: AVX2/AVX-512 families; ARM:
the optional ASIMD/SVE extensions), so that NumPy falls back to its baseline kernels.

CI runs the default test suite a second time with it (``.ci/run``): results computed with
different SIMD kernels differ in the last bits, and tests must not depend on that.  With
``--check`` it instead verifies, inside a process started with that environment, that
those features are really off (NumPy reports them as unavailable).
"""

import sys

from numpy._core import _multiarray_umath as _mu


def dispatched() -> list[str]:
    """Features NumPy was built to dispatch to and that this CPU has."""
    baseline = set(_mu.__cpu_baseline__)
    return [f for f in _mu.__cpu_dispatch__ if f not in baseline]


def main(argv) -> int:
    if "--check" in argv:
        on = [f for f in argv[argv.index("--check") + 1:] if _mu.__cpu_features__.get(f)]
        if on:
            print(f"still enabled: {' '.join(on)}", file=sys.stderr)
            return 1
        return 0
    print(" ".join(f for f in dispatched() if _mu.__cpu_features__.get(f)))
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
