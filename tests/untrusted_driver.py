"""Child process of tests/test_untrusted_fmus.py: one ``satfmu`` command over every malicious FMU.

``python -m tests.untrusted_driver JOB.json`` reads the job (the command's arguments with
``{fmu_dir}`` and ``{out}`` placeholders, the FMU folder, the malicious files by class, the
folder TMPDIR points to), puts each malicious file in the FMU folder as ``mrp_satellite.fmu``,
runs the command in this process (:func:`satfmu.sims.cli.main`) and writes, for each class, the exit
code, stderr, stdout's tail, the wall time, what was left in TMPDIR and the process's peak
resident memory so far; at the end its peak and its largest child's (ru_maxrss of the children,
which includes what each inherited from this process when it was forked: an upper bound). The first
class runs twice and its first run is not timed (imports).
"""
from __future__ import annotations

import contextlib
import io
import json
import os
import resource
import shutil
import sys
import time
from pathlib import Path


def _peak_mb() -> float:
    """This process's peak resident memory since it started its program (MB): VmHWM of
    /proc/self/status. Not ru_maxrss, which Linux carries over from the parent at fork and exec
    (a child of a 480 MB pytest worker would report 480 MB before doing anything)."""
    for line in Path("/proc/self/status").read_text().splitlines():
        if line.startswith("VmHWM:"):
            return int(line.split()[1]) / 1024
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024


def _left_in(folder: Path) -> list[str]:
    return sorted(str(p.relative_to(folder)) for p in folder.rglob("*"))


def main(job_file: str) -> int:
    """Run the job; write the results beside the job file (``.out.json``)."""
    from satfmu.sims.cli import main as satfmu

    job = json.loads(Path(job_file).read_text())
    fmu_dir, tmp = Path(job["fmu_dir"]), Path(job["tmpdir"])
    target = fmu_dir / "mrp_satellite.fmu"
    results = {}
    classes = list(job["classes"].items())
    for k, (name, path) in enumerate([classes[0]] + classes):
        shutil.copyfile(path, target)
        out = Path(job["out"]) / f"{k}"
        argv = [a.format(fmu_dir=fmu_dir, out=out) for a in job["argv"]]
        err, std = io.StringIO(), io.StringIO()
        started = time.perf_counter()
        with contextlib.redirect_stderr(err), contextlib.redirect_stdout(std):
            try:
                code = satfmu(argv)
            except SystemExit as exc:
                code = exc.code
        seconds = time.perf_counter() - started
        if k > 0:
            results[name] = {"code": code, "stderr": err.getvalue(), "stdout": std.getvalue()[-3000:],
                             "seconds": seconds, "tmp_left": _left_in(tmp),
                             "peak_mb": _peak_mb()}
        for p in tmp.iterdir():  # each class starts from an empty TMPDIR (the check above saw it)
            shutil.rmtree(p, ignore_errors=True) if p.is_dir() else p.unlink()
    peak_mb = _peak_mb()
    children_mb = resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss / 1024
    Path(job_file).with_suffix(".out.json").write_text(json.dumps(
        {"results": results, "peak_mb": peak_mb, "children_peak_mb": children_mb}))
    return 0


if __name__ == "__main__":
    os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
    sys.exit(main(sys.argv[1]))
