"""The batch run: jobs → tasks on a Dask cluster (or one after another in this process) →
every job's files in ``DIR/<job>/`` (atomically), ``DIR/manifest.json``, the summary
``DIR/summary.csv`` and ``DIR/summary.md``, progress on stderr.

* Cluster: ``scheduler`` an address (``tcp://host:8786``) to use its workers, else a
  :class:`distributed.LocalCluster` of ``workers`` processes (default: this machine's cores),
  one thread each (the tasks are numpy work that holds the GIL in places; processes scale).
  Input files are read by the workers where the jobs file names them (a shared file system
  for a remote cluster); outputs come back as bytes and the client writes them.
* Failures: a task whose worker dies (killed, out of memory) is run again by the scheduler
  (once on the local cluster: ``allowed-failures`` 1; a remote scheduler's own setting,
  Dask's default 3); a task that raises is submitted once more here; a second failure is
  reported in the summary (its job "failed" or, for a blades job, that blade) and never
  stops the other tasks. Bad input of a single command is its
  exit status, not retried. Results are taken as each task finishes and a job is written as
  soon as its last task is in, so a worker lost later loses nothing already finished.
* Re-runs: the manifest keeps, per job, the hash of its command, arguments and input files
  (:mod:`.jobs`) and the SHA-256 of every file written; a job whose hash is unchanged and
  whose files are all there with those digests is skipped.
"""

from __future__ import annotations

import hashlib
import json
import os
import shutil
import sys
import time
from dataclasses import dataclass, field
from pathlib import Path

from ..core.errors import BliskCamError
from ..core.post.common import write_atomic
from .expand import assemble, expand
from .jobs import Job, load_jobs
from .table import table_csv, table_markdown
from .tasks import execute

__all__ = ["BatchReport", "run_batch", "local_cluster", "MANIFEST"]

MANIFEST = "manifest.json"
SUMMARY_COLUMNS = ("job", "command", "status", "tasks", "attempts", "seconds", "outputs",
                   "detail")


@dataclass
class BatchReport:
    """What a batch did: ``rows`` (one dict per job, :data:`SUMMARY_COLUMNS`), the output
    folder, wall time (s), and the counts."""

    out: Path
    rows: list = field(default_factory=list)
    wall: float = 0.0

    @property
    def failed(self) -> list[str]:
        return [r["job"] for r in self.rows if r["status"] not in ("ok", "skipped")]


def _sha(data: bytes) -> str:
    return hashlib.sha256(data).hexdigest()


def _read_manifest(out: Path) -> dict:
    try:
        d = json.loads((out / MANIFEST).read_text(encoding="utf-8"))
        return d.get("jobs", {}) if isinstance(d, dict) else {}
    except (OSError, ValueError):
        return {}


def _complete(out: Path, job: Job, entry: dict | None) -> bool:
    if not entry or entry.get("hash") != job.hash or not entry.get("complete"):
        return False
    for name, digest in entry.get("files", {}).items():
        f = out / job.name / name
        if not f.is_file() or _sha(f.read_bytes()) != digest:
            return False
    return True


def write_job_files(out: Path, name: str, files: dict) -> None:
    """``DIR/<name>/`` holds exactly ``files`` ({relative name: bytes}) or, after a failure,
    what it held before: written into a hidden sibling folder and swapped in by renames."""
    tmp = out / f".{name}.partial-{os.getpid()}"
    old = out / f".{name}.old-{os.getpid()}"
    shutil.rmtree(tmp, ignore_errors=True)
    tmp.mkdir(parents=True)
    try:
        for rel, data in files.items():
            f = tmp / rel
            f.parent.mkdir(parents=True, exist_ok=True)
            with open(f, "wb") as fh:
                fh.write(data)
                fh.flush()
                os.fsync(fh.fileno())
        final = out / name
        if final.exists():
            os.replace(final, old)
        os.replace(tmp, final)
        shutil.rmtree(old, ignore_errors=True)
    except BaseException:
        shutil.rmtree(tmp, ignore_errors=True)
        raise


def local_cluster(workers: int | None = None):
    """A LocalCluster of ``workers`` processes (default: the machine's cores), one thread
    each, no dashboard. When a worker dies the scheduler runs its tasks again elsewhere once
    (``allowed-failures`` 1: the task that was running and those waiting on that worker); a
    task whose worker dies a second time is reported."""
    import dask
    from distributed import LocalCluster

    n = int(workers or os.cpu_count() or 1)
    with dask.config.set({"distributed.scheduler.allowed-failures": 1}):
        return LocalCluster(n_workers=n, threads_per_worker=1, processes=True,
                            dashboard_address=None, silence_logs=50)


class _Progress:
    """One line per finished task on stderr: ``[done/total] key: status (seconds)``."""

    def __init__(self, total: int, stream=None):
        self.total, self.done, self.stream = total, 0, stream or sys.stderr
        self.t0 = time.perf_counter()

    def __call__(self, key: str, text: str):
        self.done += 1
        width = 20
        k = int(width * self.done / max(self.total, 1))
        print(f"batch [{'#' * k}{'.' * (width - k)}] {self.done}/{self.total} {key}: {text} "
              f"({time.perf_counter() - self.t0:.1f} s)", file=self.stream, flush=True)


def run_batch(jobs, out, *, scheduler: str | None = None, workers: int | None = None,
              serial: bool = False, client=None, run_task=execute,
              stream=None) -> BatchReport:
    """Run the jobs of a TOML file (or a list of :class:`.jobs.Job`) into the folder ``out``.

    Parameters
    ----------
    jobs : path of JOBS.toml or list of Job
    out : folder (made when missing)
    scheduler : str or None — a Dask scheduler address; None: a local cluster
    workers : int or None — local cluster size (default: the cores)
    serial : bool — no cluster: the tasks one after another in this process (the reference
        run the batch must equal)
    client : a ``distributed.Client`` to use as it is (not closed here)
    run_task : the task function (:func:`.tasks.execute`; tests wrap it)
    stream : where progress goes (stderr)

    Returns
    -------
    BatchReport — also written as summary.csv and summary.md in ``out``.
    """
    t0 = time.perf_counter()
    jobs = load_jobs(jobs) if not isinstance(jobs, list) else jobs
    out = Path(out).expanduser().resolve()
    out.mkdir(parents=True, exist_ok=True)
    manifest = _read_manifest(out)
    for job in jobs:
        entry = manifest.get(job.name)
        if (out / job.name).exists() and entry is None:
            raise BliskCamError(f"{out / job.name} exists but is not this batch's (no entry in "
                                f"{out / MANIFEST}); choose another --out or move it away")
    report = BatchReport(out)
    rows = {}
    todo: list[tuple[Job, list]] = []
    for job in jobs:
        if _complete(out, job, manifest.get(job.name)):
            e = manifest[job.name]
            rows[job.name] = {"job": job.name, "command": job.command, "status": "skipped",
                              "detail": f"unchanged since the last run ({e.get('status')})",
                              "outputs": len(e.get("files", {}))}
            continue
        try:
            tasks = expand(job)
        except BliskCamError as exc:
            rows[job.name] = {"job": job.name, "command": job.command, "status": "failed",
                              "detail": " ".join(str(exc).split())}
            continue
        todo.append((job, tasks))
    progress = _Progress(sum(len(t) for _, t in todo), stream)

    def finish(job, tasks, results, attempts):
        files, row = assemble(job, tasks, results)
        complete = all("error" not in results[t.key] for t in tasks)
        write_job_files(out, job.name, files)
        manifest[job.name] = {"hash": job.hash, "status": row["status"], "complete": complete,
                              "files": {k: _sha(v) for k, v in sorted(files.items())}}
        write_atomic(out / MANIFEST, json.dumps({"version": 1, "jobs": manifest}, indent=1,
                                                sort_keys=True))
        rows[job.name] = {"job": job.name, "command": job.command, "tasks": len(tasks),
                          "attempts": attempts, "outputs": len(files), **row}

    if todo:
        if serial:
            _run_serial(todo, run_task, progress, finish)
        else:
            _run_dask(todo, run_task, progress, finish, scheduler, workers, client)
    report.rows = [rows[j.name] for j in jobs if j.name in rows]
    report.wall = time.perf_counter() - t0
    write_atomic(out / "summary.csv", table_csv(report.rows, SUMMARY_COLUMNS))
    write_atomic(out / "summary.md", table_markdown(report.rows, SUMMARY_COLUMNS))
    return report


def _error_text(exc) -> str:
    name = type(exc).__name__
    if name == "KilledWorker":
        return ("its worker died while running it, also on the second try (killed or out of "
                "memory)")
    return f"{name}: {' '.join(str(exc).split())}"


def _run_serial(todo, run_task, progress, finish):
    for job, tasks in todo:
        results, attempts = {}, 0
        for t in tasks:
            for _ in (1, 2):
                attempts += 1
                try:
                    results[t.key] = run_task(t)
                    break
                except Exception as exc:  # a bug or a crash: once more, then reported
                    results[t.key] = {"error": _error_text(exc)}
            progress(t.key, _status(results[t.key]))
        finish(job, tasks, results, attempts)


def _status(result) -> str:
    if "error" in result:
        return f"FAILED: {result['error']}"
    return result["record"].get("status", "ok")


def _run_dask(todo, run_task, progress, finish, scheduler, workers, client):
    try:
        from distributed import Client, as_completed
    except ImportError:
        raise BliskCamError("batch runs need Dask: pip install 'blisk-cam[batch]' (or "
                            "'dask[distributed]')") from None
    cluster = None
    own = client is None
    if own:
        if scheduler:
            client = Client(scheduler, timeout="20s")
        else:
            cluster = local_cluster(workers)
            client = Client(cluster)
    try:
        pending = {}
        results = {job.name: {} for job, _ in todo}
        attempts = {job.name: 0 for job, _ in todo}
        left = {job.name: len(tasks) for job, tasks in todo}
        by_name = {job.name: (job, tasks) for job, tasks in todo}

        def submit(task, attempt):
            fut = client.submit(run_task, task, key=f"{task.key}#try{attempt}-{os.getpid()}",
                                pure=False, retries=0)
            pending[fut.key] = (task, attempt)
            attempts[task.job] += 1
            return fut

        ac = as_completed([submit(t, 1) for _, tasks in todo for t in tasks])
        for fut in ac:
            task, attempt = pending.pop(fut.key)
            if fut.status == "finished":
                res = fut.result()
            else:
                exc = fut.exception()
                # a dead worker was already retried by the scheduler (its allowed-failures)
                if attempt == 1 and type(exc).__name__ != "KilledWorker":
                    print(f"batch: {task.key}: {_error_text(exc)}; trying once more",
                          file=progress.stream, flush=True)
                    ac.add(submit(task, 2))
                    fut.release()
                    continue
                res = {"error": _error_text(exc)}
            fut.release()
            results[task.job][task.key] = res
            progress(task.key, _status(res))
            left[task.job] -= 1
            if left[task.job] == 0:
                job, tasks = by_name[task.job]
                finish(job, tasks, results[task.job], attempts[task.job])
                results[task.job] = {}
    finally:
        if own:
            client.close()
            if cluster is not None:
                cluster.close()
