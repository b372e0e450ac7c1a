"""One start of the command line, as a new user meets it, with numba's compiles recorded.

    python -m validation.startup_probe SCENE SECONDS RECORD.json [HELPERS]

runs ``thesis-rbd run SCENE --seconds SECONDS --quiet [--compile-helpers HELPERS]`` in this
process (the console script's own entry point, :func:`thesis_rbd.cli.main`) under a
:class:`thesis_rbd._numba.compile_log.CompileLog`,
and writes the compiles to RECORD.json. The caller times the whole process, interpreter start
included; :mod:`validation.studies.startup` starts it in a fresh process per measurement.
"""

from __future__ import annotations

import json
import sys
from pathlib import Path
from time import perf_counter


def main(argv: list[str]) -> int:
    scene, seconds, record_path, *helpers = argv
    started = perf_counter()
    from thesis_rbd._numba.compile_log import CompileLog
    from thesis_rbd.cli import main as command_line

    imported = perf_counter() - started
    with CompileLog() as log:
        try:
            options = ["--compile-helpers", helpers[0]] if helpers else []
            command_line(["run", scene, "--seconds", seconds, "--quiet", *options])
        except SystemExit as finished:
            status = finished.code or 0
        else:
            status = 0
    record = {
        "status": status,
        "import_seconds": imported,
        "in_process_seconds": perf_counter() - started,
        "compile_seconds": log.seconds,
        "compile_cpu_seconds": log.cpu_seconds,
        "kernels_compiled": log.kernel_count,
        "compiles": [entry.to_json() for entry in log.records],
        "wait_seconds": log.wait_seconds,
    }
    Path(record_path).write_text(json.dumps(record), encoding="utf-8")
    return int(status)


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
