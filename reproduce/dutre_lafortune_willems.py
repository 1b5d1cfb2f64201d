#!/usr/bin/env python3
"""Dutré, Lafortune & Willems, "A Mathematical Framework for Global Illumination
Algorithms": the flux through a set of surfaces is the same by the rendering equation and by
the potential equation, <L, We> = <Le, W>. Estimates it both ways (gathering: paths from the
surfaces; shooting: particles from the lights) on sets of scenes/cornell-spheres.toml (a
rough gold sphere, the mirror and glass spheres, the floor under the glass), writes the
agreement as a Markdown table into docs/reproductions.md (its block
dutre-lafortune-willems:flux) and prints it.

  python3 reproduce/dutre_lafortune_willems.py

The table is computed and formatted by the test `dutre_lafortune_willems_fluxes_are_the_pages`
(tests/reproductions.rs, through the library's raylink::flux), which `cargo test` runs too
and which fails when the page holds other numbers; this script runs it with
`cargo test --release --test reproductions` (CARGO_TARGET_DIR is honoured) and copies its
table.
"""
import argparse

from common import block_from_test, write_block

NAME = 'dutre-lafortune-willems:flux'


def main():
    argparse.ArgumentParser(description=__doc__.split('\n')[0]).parse_args()
    write_block(NAME, block_from_test(['--test', 'reproductions'],
                                      'dutre_lafortune_willems_fluxes_are_the_pages', NAME))


if __name__ == '__main__':
    main()
