"""python -m rtl.gen [--check]: regenerate (or check) the generated files (rtl/generated/, hls_export/generated/)."""

import argparse
import sys

from rtl.gen import generate, latencies
from rtl.gen.repo_paths import REPO_ROOT


def main() -> int:
    ap = argparse.ArgumentParser(prog="python -m rtl.gen", description=__doc__)
    ap.add_argument("--check", action="store_true", help="only check that the files are up to date")
    args = ap.parse_args()
    stale = generate(check=args.check)
    for path in stale:
        print(f"{'stale' if args.check else 'wrote'} {path.relative_to(REPO_ROOT)}")
    for name, lat in latencies().items():
        print(f"{name}: LATENCY " + ", ".join(f"{k} {v}" for k, v in lat.items()))
    return 1 if (args.check and stale) else 0


if __name__ == "__main__":
    sys.exit(main())
