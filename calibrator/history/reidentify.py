"""``history reidentify``: identify every stored session again, on Dask, and record the results.

Each session is identified by the function the caller hands to :func:`run`:
the command line hands it one that calls identify's own function
(:func:`calibrator.identify.calibrate.run`, in a worker) with the options
``--identify-options`` reads as ``identify`` would, so a result is bit for
bit what running ``identify`` on that session gives; only its ``created``
time differs. The calibrations are
recorded in the history in the order of the sessions.
"""

from __future__ import annotations

import shlex
from collections.abc import Callable, Iterator, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

from calibrator.history.records import HistoryError

if TYPE_CHECKING:
    from calibrator.history.store import History

#: identify options that reidentify sets itself.
_OWN_OPTIONS = ("-o", "--output", "--history", "--report", "--like")


@dataclass(frozen=True)
class Job:
    """One session to identify again.

    Attributes
    ----------
    robot : str
    session : str
        The stored session file (absolute path).
    output : str
        The calibration file to write.
    """

    robot: str
    session: str
    output: str


def parse_options(text: str) -> tuple[str, ...]:
    """identify's options given as one string (``"--method lm --seed 2"``), checked.

    Raises
    ------
    HistoryError
        Unbalanced quotes, or an option reidentify sets itself.
    """
    try:
        args = tuple(shlex.split(text or ""))
    except ValueError as exc:
        raise HistoryError(f"--identify-options {text!r}: {exc}") from None
    for arg in args:
        if arg.split("=", 1)[0] in _OWN_OPTIONS:
            raise HistoryError(
                f"--identify-options: {arg} is set by reidentify (give -o DIR to reidentify)"
            )
    return args


def plan(
    store: History, robot: str | None, folder: Path, on_skip: Callable[[str, str], None]
) -> list[Job]:
    """The sessions to identify again: every stored one of ``robot`` (or of every robot).

    A session whose file is gone or changed since it was recorded is passed
    to ``on_skip(file, reason)``; a calibration file that exists is refused.

    Raises
    ------
    HistoryError
        An output file exists already (nothing is overwritten).
    """
    from calibrator import calibration

    robots = [robot] if robot is not None else [r["name"] for r in store.robots()]
    jobs = []
    for name in robots:
        for s in store.sessions(name):
            path = Path(s["file"])
            if not path.is_file():
                on_skip(s["file"], "the file is not there any more")
                continue
            if calibration.digest(path) != s["sha256"]:
                on_skip(s["file"], "the file changed since it was recorded (SHA-256 differs)")
                continue
            # Absolute: a scheduler's workers do not run in this process's folder.
            output = folder.resolve() / f"{path.stem}-{s['sha256'][:12]}.json"
            if output.exists():
                raise HistoryError(f"{output} exists: choose another -o folder or remove it")
            jobs.append(Job(name, str(path), str(output)))
    return jobs


#: ``identify(session, output, options) -> (exit code, error)``: identifies one
#: session file into ``output`` with ``options`` (what the caller made of
#: identify's options; handed through as they are).
Identify = Callable[[str, str, Any], tuple[int, str]]


def run(
    jobs: Sequence[Job],
    identify: Identify,
    options: Any = None,
    workers: int | None = None,
    scheduler: str | None = None,
) -> Iterator[tuple[Job, int, str]]:
    """identify on every job, here (neither ``workers`` nor ``scheduler``) or on Dask.

    Parameters
    ----------
    jobs : sequence of Job
    identify : Identify
        Identifies one session; a module-level function, so that Dask can
        send it to its workers by name.
    options : object
        identify's options, as ``identify`` takes them (picklable for Dask).
    workers : int, optional
        A Dask ``LocalCluster`` of this many single-threaded worker processes
        (:func:`calibrator.analysis.engine.local_cluster`).
    scheduler : str, optional
        An existing Dask scheduler; its workers read the session files at
        the paths the history stores.

    Yields
    ------
    job : Job
    code : int
        identify's exit code (0: the calibration is written).
    error : str
        identify's refusal (one line), when ``code`` is not 0.

    In job order, each as soon as it and every job before it are done, so
    the caller records while the workers compute.
    """
    from calibrator.analysis import engine

    if workers is None and scheduler is None:
        for job in jobs:
            yield (job, *identify(job.session, job.output, options))
        return
    client, cluster = engine.connect(workers, scheduler)
    try:
        from dask.distributed import as_completed

        futures = [
            client.submit(identify, job.session, job.output, options, pure=False) for job in jobs
        ]
        index = {f.key: i for i, f in enumerate(futures)}
        done: dict[int, tuple[int, str]] = {}
        following = 0
        for future in as_completed(futures):
            done[index[future.key]] = future.result()
            while following in done:
                yield (jobs[following], *done.pop(following))
                following += 1
    finally:
        engine.close(client, cluster)
