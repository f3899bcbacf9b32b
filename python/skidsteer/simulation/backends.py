"""Where simulations run: threads on this machine, or tasks on a Ray cluster.

A sweep or a diagnosis is many independent runs.  The driver builds each model
and settles it once; a backend then maps one module-level function over the
runs and hands back the results in order:

- ``LocalBackend(nthread)``: a thread pool on this machine (mujoco.rollout
  releases the GIL, so nthread runs step at once);
- ``RayBackend(address)``: one Ray task per run (``pip install skidsteer[ray]``).
  Models and settled states go to the object store once (``share``) and reach
  the tasks pickled (``mj_saveModel``, which is exact), so a run on Ray starts
  from the very bytes a local run starts from and gives the same numbers.

Every worker needs skidsteer and the driver's mujoco version: the plugin is
compiled against one libmujoco.  Ray workers check this when they start and
fail with a message saying which version they have.
"""

from __future__ import annotations

import os
from concurrent.futures import ThreadPoolExecutor
from typing import Any, Callable, Iterator, Sequence

import mujoco

from skidsteer.version import __version__

BACKENDS = ("local", "ray")
RAY_EXTRA_MISSING = ("the Ray backend needs the ray extra: pip install 'skidsteer[ray]' "
                     "(ray is not installed in this environment)")
_VERSIONS_ENV = "SKIDSTEER_DRIVER_VERSIONS"


class BackendUnavailable(RuntimeError):
    """The backend asked for cannot run here (its extra is not installed)."""


class LocalBackend:
    """nthread runs at a time in this process's threads."""

    name = "local"

    def __init__(self, nthread: int = 2):
        if nthread < 1:
            raise ValueError(f"nthread must be at least 1, got {nthread}")
        self.nthread = int(nthread)
        self.concurrency = self.nthread

    def share(self, obj: Any) -> Any:
        return obj

    def map(self, fn: Callable, args: Sequence[tuple]) -> Iterator:
        """fn(*a) for a in args, in order; at most nthread at a time."""
        with ThreadPoolExecutor(max_workers=self.nthread) as pool:
            yield from pool.map(lambda a: fn(*a), args)

    def close(self) -> None:
        pass

    def __repr__(self) -> str:
        return f"LocalBackend(nthread={self.nthread})"


class RayBackend:
    """One Ray task per run on the cluster at `address` (None: a Ray instance on this
    machine, started if none runs; "auto": the one already running; "ray://host:10001":
    a remote cluster through Ray Client).  Each task takes one CPU."""

    name = "ray"

    def __init__(self, address: str | None = None, **init_kwargs):
        try:
            import ray
        except ImportError as err:
            raise BackendUnavailable(RAY_EXTRA_MISSING) from err
        self._ray = ray
        self._started = False
        if not ray.is_initialized():
            runtime_env = dict(init_kwargs.pop("runtime_env", None) or {})
            runtime_env.setdefault("worker_process_setup_hook",
                                   "skidsteer.simulation.backends.worker_setup")
            env_vars = dict(runtime_env.get("env_vars") or {})
            env_vars[_VERSIONS_ENV] = _versions()
            runtime_env["env_vars"] = env_vars
            init_kwargs.setdefault("include_dashboard", False)
            init_kwargs.setdefault("log_to_driver", False)
            ray.init(address=address, runtime_env=runtime_env, **init_kwargs)
            self._started = True
        self.concurrency = max(1, int(ray.cluster_resources().get("CPU", 1)))
        self._remote: dict[Callable, Any] = {}

    def share(self, obj: Any) -> Any:
        """A reference the tasks resolve to obj (stored once, however many tasks use it)."""
        return self._ray.put(obj)

    def map(self, fn: Callable, args: Sequence[tuple]) -> Iterator:
        """fn(*a) for a in args as Ray tasks, all submitted at once; results in order."""
        remote = self._remote.get(fn)
        if remote is None:
            remote = self._remote[fn] = self._ray.remote(num_cpus=1)(fn)
        # the refs of the latest map are kept for inspection (tests/test_backends.py)
        refs = self._last_refs = [remote.remote(*a) for a in args]
        failures = self._ray.exceptions
        consumed = 0
        try:
            for ref in refs:
                try:
                    result = self._ray.get(ref)
                    consumed += 1
                    yield result
                except (failures.WorkerCrashedError, failures.RaySystemError,
                        failures.RuntimeEnvSetupError) as err:
                    # an exception of our own code comes through as itself; this is
                    # a worker that died or could not start
                    raise BackendUnavailable(
                        f"a Ray worker failed to run {fn.__name__}: {type(err).__name__}: "
                        f"{str(err).splitlines()[0] if str(err) else ''} (workers need "
                        f"{_versions()} with the tire plugin; a worker that cannot start "
                        "says why in the raylet's message above)") from err
        finally:
            # a consumer that stops early leaves nothing queued (waiting tasks are
            # cancelled, running ones interrupted); but only the tasks still pending
            # are cancelled: ray.cancel on a task whose result is in but
            # whose completion the driver has not booked yet kills the driver (Ray's
            # fatal check "Tried to complete task that was not pending",
            # ray-project/ray#54846; 2 of 4 runs of the Ray diagnosis test here, Ray 2.60)
            rest = refs[consumed:]
            if rest:
                _, pending = self._ray.wait(rest, num_returns=len(rest), timeout=0)
                for ref in pending:
                    self._ray.cancel(ref)

    def close(self) -> None:
        if self._started:
            self._ray.shutdown()
            self._started = False

    def __repr__(self) -> str:
        return f"RayBackend(concurrency={self.concurrency})"


def make_backend(name: str = "local", *, nthread: int = 2, address: str | None = None,
                 **ray_kwargs) -> LocalBackend | RayBackend:
    """The backend called `name` ("local" or "ray")."""
    if name == "local":
        if address is not None:
            raise ValueError("--address is for the ray backend; the local backend runs "
                             "on this machine")
        return LocalBackend(nthread)
    if name == "ray":
        return RayBackend(address, **ray_kwargs)
    raise ValueError(f"unknown backend {name!r}; choose one of {', '.join(BACKENDS)}")


def _versions() -> str:
    return f"mujoco=={mujoco.__version__} skidsteer=={__version__}"


def worker_setup() -> None:
    """Runs in every Ray worker before its first task: registers the tire plugin (the
    models arrive pickled and need it to load) and checks that the worker runs the
    driver's mujoco and skidsteer."""
    # importing this module imported skidsteer, which registered skidsteer.tire
    driver = os.environ.get(_VERSIONS_ENV)
    mine = _versions()
    if driver and driver != mine:
        raise RuntimeError(f"Ray worker on {os.uname().nodename} has {mine}, the driver has "
                           f"{driver}: install the driver's versions on every node")
