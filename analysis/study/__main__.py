"""`python -m analysis.study [--out=DIR]`: rebuilds the study's claims, numbers and report."""

from __future__ import annotations

if __name__ == "__main__":  # this program never renders a scene: no OpenGL backend
    from cpg_suite import cli

    cli.without_rendering()

import os

from absl import flags

from analysis.study import build, report
from analysis.study.evidence import Evidence
from cpg_suite import cli


def main(argv: list[str]) -> None:
    del argv
    try:
        report.require_matplotlib()
    except report.MissingExtra as e:
        raise cli.UsageError(str(e)) from None
    ev = Evidence()
    for path in (ev.study, ev.protocol):
        cli.check(os.path.isdir(path), f"{path} not found: run from the repository's root")
    print(build.build(flags.FLAGS.out, ev))


if __name__ == "__main__":
    flags.DEFINE_string("out", build.OUT, "Folder of claims.csv, numbers.csv and report.md.")
    cli.run(main, output_dirs=("out",))
