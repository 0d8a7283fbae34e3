"""Episodes on Ray actors: ``--ray`` (a Ray started on this machine) or ``--ray ADDRESS`` (a
cluster started with ``ray start --head``, or KubeRay's head service); docs/ray.md.

Imported only when ``--ray`` is given (``training.runs.runner.open_backend``): the default install
needs no Ray. Each actor builds its ``EpisodeRunner`` once and runs many jobs on it, two in
flight at a time so that it never waits for the driver. Results come back through the same
interface as the local worker processes (``training.runs.runner.Backend``): in job order for
``imap``, as they arrive for ``as_completed``.

A worker process that dies (killed, out of memory, its node lost) loses its actor: a new
actor is started and the jobs the old one held run again. A job that was alone on a dying
actor counts a try, up to ``retries``; then ``WorkerLost`` names it (after every other result
was handed out). When a dying actor held two jobs, neither is blamed (a finished job's result
can die with the process): both go back and that slot runs one job at a time from then on.
Leaving the block early (Ctrl-C, an error) kills the actors, which cancels the remote work,
and stops a Ray that this process started.

What cannot run fails before any job, as a ``ClusterError`` (a ``ValueError``: the commands
exit 2 with its one line): Ray not installed, an address nobody answers at, workers that
cannot import this package or run another version of it, and (``check_each``) a worker
that cannot open a file a job needs.
"""

from __future__ import annotations

import logging
import os
import socket
import sys
from collections import deque
from collections.abc import Callable, Iterable, Iterator

from .base import Backend, BackendError, WorkerLost, make_runner


def use_token_if_there_is_one() -> None:
    """Send this machine's Ray token when joining a cluster. Ray 2.60's ``ray start --head``
    makes a cluster that wants its token (``~/.ray/auth_token``), but ``ray.init(address=)``
    sends it only if ``RAY_AUTH_MODE=token`` was set before ``import ray`` (Ray reads it
    then): without it, joining failed after 20 s of "Authentication token is missing or
    incorrect". An explicit ``RAY_AUTH_MODE`` is kept; a Ray started here makes token clusters
    by default anyway. Once Ray is imported it is too late (and the processes it starts
    would get a mode that its own does not match): nothing is changed then."""
    global _TOKEN_SET_HERE
    if "ray" in sys.modules:
        return
    token_file = os.environ.get("RAY_AUTH_TOKEN_PATH") or os.path.expanduser("~/.ray/auth_token")
    if "RAY_AUTH_MODE" not in os.environ and (os.environ.get("RAY_AUTH_TOKEN")
                                              or os.path.isfile(token_file)):
        os.environ["RAY_AUTH_MODE"] = "token"
        _TOKEN_SET_HERE = True


_TOKEN_SET_HERE = False


use_token_if_there_is_one()
try:
    import ray
except ImportError:  # pragma: no cover - the message says what to install
    ray = None

IN_FLIGHT = 2  # jobs queued per actor: one running, one waiting, so none idles between jobs
START_TIMEOUT_S = 300.0  # actors that are not up by then: the cluster lacks room or packages
LOCAL_OBJECT_STORE_BYTES = 200 * 1024**2  # results are a few rows: keep /dev/shm for others


class ClusterError(BackendError):
    """Ray cannot run the jobs; the message names the cause and the fix."""


class _Worker:
    """One actor: a runner built once, then jobs on it."""

    def __init__(self, runner_args: tuple | None, job: Callable):
        try:  # one torch thread per worker (shared/PITFALLS.md)
            import torch

            torch.set_num_threads(1)
        except ImportError:
            pass
        self.runner, self.job = make_runner(runner_args), job

    def where(self) -> dict:
        import cmdp_pymunk

        return {"host": socket.gethostname(), "pid": os.getpid(),
                "version": cmdp_pymunk.__version__}

    def run(self, args: tuple):
        return self.job(self.runner, *args)

    def call(self, fn: Callable, args: tuple):
        return fn(self.runner, *args)


def check_address(address: str, timeout_s: float = 5.0) -> None:
    """``HOST:PORT`` (or ``ray://HOST:PORT``) must answer within ``timeout_s``: Ray itself
    retries an unreachable address for a minute or more before it says so."""
    if address == "auto":
        return
    hostport = address.split("://", 1)[-1]
    host, sep, port = hostport.rpartition(":")
    if not sep or not port.isdigit():
        raise ClusterError(f"--ray {address!r} is not an address; fix: give HOST:PORT of the "
                           "cluster's head (ray start --head prints it), e.g. 10.0.0.5:6379, "
                           "or 'auto', or --ray alone for a Ray on this machine")
    try:
        with socket.create_connection((host, int(port)), timeout=timeout_s):
            pass
    except OSError as err:
        raise ClusterError(f"--ray {address}: no Ray cluster answers there ({err}); fix: start "
                           "one with `ray start --head` on that machine, check the address "
                           "it printed, or use --ray alone for a Ray on this machine") from None


def require_ray() -> None:
    """ClusterError (one line: what to install) where Ray is not installed."""
    if ray is None:
        raise ClusterError("--ray needs Ray, which is not installed; fix: "
                           "pip install -e '.[ray]' (docs/ray.md), or drop --ray")


def connect(address: str, cpus: int | None = None) -> bool:
    """Connect this process to Ray: ``address="local"`` starts one here with ``cpus`` CPUs
    (None: every core), anything else joins that cluster (checked to answer first). True if
    this call connected (the caller then calls ``ray.shutdown()``); False where this process
    was connected already (a test's cluster). ClusterError, naming the fix, if it cannot."""
    require_ray()
    if ray.is_initialized():
        return False
    if address == "local":
        from .base import default_workers

        ray.init(num_cpus=cpus or default_workers(), include_dashboard=False,
                 object_store_memory=LOCAL_OBJECT_STORE_BYTES, logging_level=logging.WARNING)
        return True
    check_address(address)
    try:
        ray.init(address=address, logging_level=logging.WARNING)
    except (ConnectionError, RuntimeError) as err:  # RuntimeError: Ray versions differ
        raise ClusterError(f"--ray {address}: cannot join the cluster ({err}); "
                           "fix: check the address `ray start --head` printed, that "
                           "this machine runs the cluster's Ray version "
                           f"({ray.__version__} here) and has the cluster's token "
                           "(~/.ray/auth_token or RAY_AUTH_TOKEN; docs/ray.md)") from None
    return True


def check_workers(found: list[dict], address: str) -> None:
    """The answers of ``where()`` from every actor: ClusterError if one runs another version
    of this package."""
    import cmdp_pymunk

    other = sorted({(w["host"], w["version"]) for w in found
                    if w["version"] != cmdp_pymunk.__version__})
    if other:
        raise ClusterError(
            f"--ray {address}: workers run another cmdp-pymunk ("
            + ", ".join(f"{v} on {h}" for h, v in other)
            + f"; {cmdp_pymunk.__version__} here); fix: install the same version on "
            "every node")


def cannot_run_here(address: str, err: BaseException) -> ClusterError:
    """The error for actors that could not start: the workers lack this package."""
    import cmdp_pymunk

    return ClusterError(
        f"--ray {address}: the Ray workers cannot run this package "
        f"({str(err).strip().splitlines()[-1]}); fix: install cmdp-pymunk "
        f"{cmdp_pymunk.__version__} on every node (pip install -e '.[ray]')"
        + ("; if the cluster runs without Ray tokens, set RAY_AUTH_MODE=disabled here"
           " too (this machine has a token and sent it)" if _TOKEN_SET_HERE else ""))


class RayWorkers(Backend):
    """``job(runner, *args)`` on Ray actors, each with its own ``EpisodeRunner(*runner_args)``.

    ``ray="local"``: start Ray here with ``workers`` CPUs (None: every core); an address: join
    that cluster, with ``workers`` actors (None: one per CPU of the cluster). A Ray this
    process is already connected to (a test's cluster) is used as it is.
    """

    def __init__(self, job: Callable, runner_args: tuple | None, workers: int | None,
                 ray_address: str, retries: int = 1):
        require_ray()
        self.job, self.runner_args, self.address = job, runner_args, ray_address
        self.workers, self.retries = workers, retries
        self._started = False
        self._actors: list = []
        self.label = "Ray"

    # -- connecting --------------------------------------------------------------------------

    def __enter__(self) -> RayWorkers:
        try:
            self._connect()
            self._start_actors()
        except BaseException:
            self.__exit__(None, None, None)
            raise
        return self

    def _connect(self) -> None:
        self._started = connect(self.address, self.workers)

    def _start_actors(self) -> None:

        cpus = int(ray.cluster_resources().get("CPU", 0))
        if cpus < 1:
            raise ClusterError(f"--ray {self.address}: the cluster has no CPU to run on; fix: "
                               "start its workers with --num-cpus 1 or more")
        self.workers = self.workers or cpus
        where = self.address if self.address != "local" else "this machine"
        self.label = f"Ray on {where}, {self.workers} actor(s) ({cpus} CPU(s))"
        self._actors = [self._new_actor() for _ in range(self.workers)]
        try:
            found = ray.get([a.where.remote() for a in self._actors], timeout=START_TIMEOUT_S)
        except ray.exceptions.GetTimeoutError:
            raise ClusterError(f"--ray {self.address}: {self.workers} actor(s) did not start "
                               f"in {START_TIMEOUT_S:.0f} s; fix: give --workers at most the "
                               f"cluster's free CPUs ({cpus})") from None
        except (ray.exceptions.RayError, ImportError) as err:
            raise cannot_run_here(self.address, err) from None
        check_workers(found, self.address)
        self.hosts = sorted({w["host"] for w in found})

    def _new_actor(self):
        return _Actor.options(num_cpus=1, max_restarts=0,
                              scheduling_strategy="SPREAD").remote(self.runner_args, self.job)

    def check_each(self, fn: Callable, *args) -> list:
        """``fn(runner, *args)`` once on every actor; their answers."""
        return ray.get([a.call.remote(fn, args) for a in self._actors])

    # -- running ----------------------------------------------------------------------------

    def as_completed(self, jobs: Iterable[tuple]) -> Iterator[tuple[int, object]]:
        jobs = list(jobs)
        queue = deque(range(len(jobs)))
        tries = [0] * len(jobs)
        lost: list[int] = []
        inflight: dict = {}  # ref -> (job index, actor slot)
        load = [0] * len(self._actors)
        depth = [IN_FLIGHT] * len(self._actors)  # jobs a slot's actor may hold

        def submit(slot: int) -> None:
            while queue and load[slot] < depth[slot]:
                i = queue.popleft()
                inflight[self._actors[slot].run.remote(jobs[i])] = (i, slot)
                load[slot] += 1

        for slot in range(len(self._actors)):
            submit(slot)
        while inflight:
            [ref], _ = ray.wait(list(inflight), num_returns=1)
            i, slot = inflight[ref]
            try:
                result = ray.get(ref)
            except ray.exceptions.RayActorError:  # the worker process died: a new actor
                # Which job killed it is known only when it held one: a job that finished
                # just before the death can lose its result with the process (seen on a
                # loaded machine). So a death with several jobs held sends them all back
                # untried and its slot takes one job at a time from then on; a death with
                # one job held counts a try against that job.
                held = [(r, j) for r, (j, s) in inflight.items() if s == slot]
                for r, _ in held:
                    del inflight[r]
                if len(held) == 1:
                    j = held[0][1]
                    tries[j] += 1
                    if tries[j] > self.retries:
                        lost.append(j)
                    else:
                        queue.appendleft(j)
                else:
                    depth[slot] = 1
                    queue.extendleft(j for _, j in reversed(held))
                self._kill(self._actors[slot])
                self._actors[slot] = self._new_actor()
                load[slot] = 0
                submit(slot)
                continue
            del inflight[ref]
            load[slot] -= 1
            submit(slot)
            yield i, result
        if lost:
            raise WorkerLost(lost, self.retries)

    # -- stopping ---------------------------------------------------------------------------

    @staticmethod
    def _kill(actor) -> None:
        try:
            ray.kill(actor, no_restart=True)
        except Exception:  # noqa: BLE001 - already gone
            pass

    def __exit__(self, *exc) -> None:
        for actor in self._actors:  # kills the worker process: its jobs stop with it
            self._kill(actor)
        self._actors = []
        if self._started:
            ray.shutdown()
            self._started = False


_Actor = ray.remote(_Worker) if ray is not None else None
