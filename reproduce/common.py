"""What the scripts of reproduce/ share: the repository's top and their command line."""
import argparse
import os
import sys

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


def image_args(doc):
    """The options of a script that renders images: --raylink (the binary, checked) and
    --out (where the images go, made)."""
    ap = argparse.ArgumentParser(description=doc.split('\n')[0])
    ap.add_argument('--raylink', default=os.path.join(ROOT, 'target/release/raylink'))
    ap.add_argument('--out', default=os.path.join(ROOT, 'docs/images'))
    args = ap.parse_args()
    if not os.access(args.raylink, os.X_OK):
        sys.exit(f'no {args.raylink}: cargo build --release first (or give --raylink)')
    os.makedirs(args.out, exist_ok=True)
    return args
