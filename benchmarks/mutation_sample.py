"""A seeded random sample of a package's mutmut mutants, one name a line.

A complete mutmut run of a large package takes hours on a shared machine;
the score of a simple random sample of its mutants estimates the package's
score (within about 2 sqrt(p (1 - p) / n) for n mutants). The names are
generated the way ``mutmut run`` generates them (mutmut's own mutation of
each file), in one seeded permutation: the first N lines of a longer sample
are a sample of N. Feed them to mutmut::

    python benchmarks/mutation_sample.py calibrator/check 100 > check.names
    nice -n 19 mutmut run --max-children 2 $(cat check.names)

A package spread over several places takes them all, folders and single
files, before the sample size; their mutants are pooled (each file once, in
path order) and sampled together::

    python benchmarks/mutation_sample.py calibrator/languages \
        calibrator/compensate/programs.py calibrator/compensate/solve.py 150

Run from the repository root with mutmut importable (see
docs/mutation-testing.md).
"""

import argparse
import io
import random
import sys
from pathlib import Path


def source_files(paths: list[Path]) -> list[Path]:
    """The ``.py`` files of ``paths`` (folders recursively, files as given), sorted, each once."""
    files: set[Path] = set()
    for path in paths:
        if path.is_dir():
            files.update(path.rglob("*.py"))
        elif path.is_file() and path.suffix == ".py":
            files.add(path)
        else:
            raise ValueError(f"{path} is neither a folder nor a .py file")
    return sorted(files)


def mutant_names(*paths: Path) -> list[str]:
    """Every mutant mutmut makes of the ``.py`` files of ``paths``, in file order.

    One folder gives the same list (and so, with the same seed, the same
    sample) as before several paths were accepted.
    """
    from mutmut.__main__ import write_all_mutants_to_file
    from mutmut.utils.format_utils import get_mutant_name

    names = []
    for path in source_files(list(paths)):
        made = write_all_mutants_to_file(out=io.StringIO(), source=path.read_text(), filename=path)
        names += [get_mutant_name(path, name) for name in made.mutant_names]
    return names


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument(
        "paths", type=Path, nargs="+", help="package folders or .py files, e.g. calibrator/check"
    )
    parser.add_argument("n", type=int, help="sample size")
    parser.add_argument("--seed", type=int, default=44)
    parser.add_argument("--count", action="store_true", help="print the number of mutants only")
    args = parser.parse_args(argv)
    try:
        names = mutant_names(*args.paths)
    except ValueError as error:
        print(f"mutation_sample.py: {error}", file=sys.stderr)
        raise SystemExit(2) from None
    if args.count:
        print(len(names))
        return
    for name in random.Random(args.seed).sample(names, min(args.n, len(names))):
        print(name)


if __name__ == "__main__":
    main()
