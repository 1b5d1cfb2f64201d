"""What the scripts of reproduce/ share: the repository's top, their command line, and the
blocks of the pages they write their tables into."""
import argparse
import os
import subprocess
import sys

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
PAGE = os.path.join(ROOT, 'docs/reproductions.md')

# Set for the library's tests the scripts run: print the tables, do not compare them with
# the page (which the script is about to rewrite).
PRINT_ONLY = 'RAYLINK_REPRODUCE_PRINT_ONLY'


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


def markers(name):
    return f'<!-- BEGIN {name} -->', f'<!-- END {name} -->'


def block_of(text, name):
    """What `text` holds between the markers of block `name`, or None."""
    begin, end = markers(name)
    start, stop = text.find(begin), text.find(end)
    if start < 0 or stop < start:
        return None
    return text[start + len(begin):stop].strip()


def write_block(name, table, page=PAGE):
    """Prints `table` and puts it between the markers of block `name` of `page`."""
    print(table.strip() + '\n')
    with open(page) as f:
        text = f.read()
    begin, end = markers(name)
    start, stop = text.find(begin), text.find(end)
    if start < 0 or stop < start:
        sys.exit(f'{os.path.relpath(page, ROOT)} has no {begin} ... {end}')
    text = text[:start + len(begin)] + '\n' + table.strip() + '\n' + text[stop:]
    with open(page, 'w') as f:
        f.write(text)


def block_from_test(target, test, name):
    """The block `name` that the test `test` of the cargo target `target` (such as
    ['--test', 'reproductions']) prints, run in release without comparing with the page."""
    cmd = ['cargo', 'test', '--quiet', '--release'] + target + ['--', test, '--exact',
                                                                 '--nocapture']
    run = subprocess.run(cmd, cwd=ROOT, capture_output=True, text=True,
                         env={**os.environ, PRINT_ONLY: '1'})
    table = block_of(run.stderr, name)
    if run.returncode != 0 or not table:
        sys.exit(f"{' '.join(cmd)} failed:\n{run.stdout}\n{run.stderr}")
    return table
