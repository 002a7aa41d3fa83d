"""A seeded random sample of a package's mutmut mutants, one name a line.

A complete mutmut run of a large package takes hours on a shared machine;
the score of a simple random sample of its mutants estimates the package's
score (within about 2 sqrt(p (1 - p) / n) for n mutants). The names are
generated the way ``mutmut run`` generates them (mutmut's own mutation of
each file), in one seeded permutation: the first N lines of a longer sample
are a sample of N. Feed them to mutmut::

    python benchmarks/mutation_sample.py calibrator/check 100 > check.names
    nice -n 19 mutmut run --max-children 2 $(cat check.names)

Run from the repository root with mutmut importable (see
docs/mutation-testing.md).
"""

import argparse
import io
import random
from pathlib import Path


def mutant_names(folder: Path) -> list[str]:
    """Every mutant mutmut makes of the ``.py`` files under ``folder``, in file order."""
    from mutmut.__main__ import write_all_mutants_to_file
    from mutmut.utils.format_utils import get_mutant_name

    names = []
    for path in sorted(folder.rglob("*.py")):
        made = write_all_mutants_to_file(out=io.StringIO(), source=path.read_text(), filename=path)
        names += [get_mutant_name(path, name) for name in made.mutant_names]
    return names


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("folder", type=Path, help="package folder, e.g. calibrator/check")
    parser.add_argument("n", type=int, help="sample size")
    parser.add_argument("--seed", type=int, default=44)
    parser.add_argument("--count", action="store_true", help="print the number of mutants only")
    args = parser.parse_args(argv)
    names = mutant_names(args.folder)
    if args.count:
        print(len(names))
        return
    for name in random.Random(args.seed).sample(names, min(args.n, len(names))):
        print(name)


if __name__ == "__main__":
    main()
