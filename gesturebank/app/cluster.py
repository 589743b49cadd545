"""The Ray executor of `build-dataset`: connect to the cluster a user has, check that every node
sees the same OUT_DIR, VIDEOS_DIR and gesturebank, size each take's task, survive lost workers.

Connecting. `--ray-address` (or RAY_ADDRESS) is `auto` (the cluster `ray start` left on this
machine), `HOST:PORT` (the head's GCS port) or `ray://HOST:PORT` (Ray Client); none starts a
private Ray. A head started on a machine that holds a Ray token (~/.ray/auth_token, written by
any earlier local `ray.init()`) requires it, but Ray sends it only for `auto`; for a head on this
machine (loopback or one of its addresses) we send it as `auto` would. A token never goes to
another machine unless RAY_AUTH_MODE=token says so.

Memory of a take's task (Ray's `memory` resource), from its videos' probed headers:
    build.ray_memory_base_mb + frames × build.ray_memory_per_frame_kb
    + width × height × 3 bytes × (decode threads + 2)   (decoded frames in flight)
where frames = duration × fps; clamped to the largest node's memory.
"""

from __future__ import annotations

import ipaddress
import logging
import os
import signal
import socket
import threading
import uuid
from collections.abc import Generator, Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Any

from gesturebank.app.take_job import (
    ChunkJob,
    Job,
    Schedule,
    TakeResult,
    record_failure,
    record_stamp,
    run_chunk,
    run_take,
    written_result,
)
from gesturebank.config import Config
from gesturebank.datasets import store
from gesturebank.datasets.takes import Take
from gesturebank.errors import InputError

log = logging.getLogger(__name__)

PROBE_PREFIX = ".gesturebank-probe-"
TOKEN_HINT = (
    "if the head uses token authentication, set RAY_AUTH_MODE=token and RAY_AUTH_TOKEN to its "
    "token (`ray get-auth-token` on the head)"
)


def resolve_address(address: str | None) -> str | None:
    """The cluster to use: as given, else RAY_ADDRESS, else None (start a private Ray)."""
    return address or os.environ.get("RAY_ADDRESS") or None


def split_address(address: str) -> tuple[str, int]:
    """'HOST:PORT' (or 'ray://HOST:PORT', '[v6]:PORT') → (host, port); InputError if malformed."""
    rest = address.removeprefix("ray://")
    host, sep, port = rest.rpartition(":")
    host = host.strip("[]")
    if not sep or not host or not port.isdigit():
        raise InputError(
            f"--ray-address {address}: not an address: give auto, HOST:PORT or ray://HOST:PORT"
        )
    return host, int(port)


def is_this_machine(host: str) -> bool:
    """True for a loopback name or address, or one of this machine's own addresses."""
    try:
        ips = {str(info[4][0]) for info in socket.getaddrinfo(host, None)}
    except OSError:
        return False
    own = {"127.0.0.1", "::1"}
    for name in (socket.gethostname(), socket.getfqdn()):
        try:
            own |= {str(info[4][0]) for info in socket.getaddrinfo(name, None)}
        except OSError:
            pass
    try:
        from ray.util import get_node_ip_address

        own.add(get_node_ip_address())  # the address Ray rewrites a loopback host to
    except Exception:  # no Ray, or no route: the names above are enough
        pass
    return any(ipaddress.ip_address(ip.split("%")[0]).is_loopback or ip in own for ip in ips)


def _answers(host: str, port: int, timeout_s: float) -> bool:
    try:
        with socket.create_connection((host, port), timeout=timeout_s):
            return True
    except OSError:
        return False


def _send_local_token() -> None:
    """Enable token authentication when a token exists and RAY_AUTH_MODE is unset, as Ray does
    for `auto` (older Rays have no tokens: nothing to do)."""
    try:
        from ray._private.authentication.authentication_token_setup import (
            maybe_enable_token_auth_if_token_available,
        )
    except ImportError:
        return
    maybe_enable_token_auth_if_token_available(warn_if_disabled=False)


def _one_line(exc: BaseException) -> str:
    text = " ".join(str(exc).split()) or type(exc).__name__
    return text if len(text) < 200 else text[:197] + "..."


# A Ray Client head starts one server process per client; on a busy head that start can fail
# once (the process exits before it listens) and the next client gets a fresh one.
CLIENT_START_ATTEMPTS = 3


def _init(ray: Any, address: str | None) -> None:
    for attempt in range(1, CLIENT_START_ATTEMPTS + 1):
        try:
            # "local": a private Ray, not the cluster a stale /tmp/ray/ray_current_cluster names
            ray.init(address=address or "local", include_dashboard=False, log_to_driver=False)
            return
        except ConnectionError as exc:
            server_start_failed = "Initialization failure from server" in str(exc)
            if not server_start_failed or attempt == CLIENT_START_ATTEMPTS:
                raise
            log.warning("%s: the head's client server did not start; retrying", address)


@contextmanager
def connected(address: str | None, config: Config) -> Iterator[Any]:
    """Ray, connected to `address` (see the module docstring) for the block; InputError with one
    line naming the address and what to try when it cannot connect."""
    try:
        import ray
    except ImportError:
        raise InputError(
            "--executor ray needs Ray: pip install 'gesturebank[distributed]'"
        ) from None
    if ray.is_initialized():  # the caller's own connection: theirs to close
        yield ray
        return
    address = resolve_address(address)
    if address and address != "auto":
        host, port = split_address(address)
        if address.startswith("ray://"):
            try:
                import grpc  # noqa: F401  Ray Client's transport
            except ImportError:
                raise InputError(
                    f"--ray-address {address}: Ray Client needs pip install 'ray[client]'; or "
                    f"give the head's HOST:PORT (its GCS port, 6379 unless `ray start --port`)"
                ) from None
        if not _answers(host, port, config.build.ray_connect_timeout_s):
            raise InputError(
                f"--ray-address {address}: nothing answers there: start the head "
                f"(`ray start --head --port {port}`) or check the address and firewall"
            )
        if is_this_machine(host):
            _send_local_token()
    handler = signal.getsignal(signal.SIGTERM)
    try:
        _init(ray, address)
    except Exception as exc:  # Ray raises ConnectionError, RuntimeError, AuthenticationError…
        where = address or "a private Ray"
        if address == "auto":
            hint = "start one with `ray start --head` or give --ray-address HOST:PORT"
        elif os.environ.get("RAY_AUTH_MODE", "").lower() != "token":
            hint = TOKEN_HINT
        else:
            hint = "check that RAY_AUTH_TOKEN is the head's token and the versions match"
        msg = f"--ray-address {where}: cannot connect ({_one_line(exc)}); {hint}"
        raise InputError(msg) from None
    if handler is not None and threading.current_thread() is threading.main_thread():
        signal.signal(signal.SIGTERM, handler)  # Ray's sys.exit()s: SIGTERM stops as Ctrl-C
    try:
        yield ray
    finally:
        ray.shutdown()


def node_sees(*, probe: str, secret: str, videos_dir: str, version: str) -> list[str]:
    """Run on a node: what it does not share with the driver (empty when all is well)."""
    import ray

    import gesturebank

    ctx = ray.get_runtime_context()
    node = f"{ray.util.get_node_ip_address()} ({ctx.get_node_id()[:8]})"
    problems = []
    try:
        seen = Path(probe).read_text() == secret
    except OSError:
        seen = False
    if not seen:
        out = Path(probe).parent
        problems.append(f"OUT_DIR {out} is not shared with node {node}: mount it at the same path")
    if not Path(videos_dir).is_dir():
        problems.append(
            f"VIDEOS_DIR {videos_dir} is not shared with node {node}: mount it at the same path"
        )
    if gesturebank.__version__ != version:
        problems.append(
            f"node {node} runs gesturebank {gesturebank.__version__}, the driver {version}: "
            "install the same version on every node"
        )
    return problems


def check_storage(ray: Any, *, out: Path, videos_dir: Path, config: Config) -> None:
    """One task per live node checks it sees a probe the driver wrote into `out`, `videos_dir`
    and the driver's gesturebank version; InputError with one line per problem."""
    from ray.util.scheduling_strategies import NodeAffinitySchedulingStrategy

    import gesturebank

    probe = Path(out) / f"{PROBE_PREFIX}{uuid.uuid4().hex}"
    secret = uuid.uuid4().hex
    probe.write_text(secret)
    try:
        check = ray.remote(node_sees)
        nodes = {
            check.options(
                num_cpus=0,  # runs beside busy tasks
                scheduling_strategy=NodeAffinitySchedulingStrategy(node["NodeID"], soft=False),
            ).remote(
                probe=str(probe.resolve()),
                secret=secret,
                videos_dir=str(Path(videos_dir).resolve()),
                version=gesturebank.__version__,
            ): node
            for node in ray.nodes()
            if node["Alive"]
        }
        timeout = config.build.ray_check_timeout_s
        done, late = ray.wait(list(nodes), num_returns=len(nodes), timeout=timeout)
        if late:
            names = ", ".join(nodes[ref]["NodeManagerAddress"] for ref in late)
            raise InputError(
                f"Ray: node(s) {names} did not answer the storage check within {timeout:g} s: "
                "check `ray status`"
            )
        answers = []
        for ref in done:
            try:
                answers.append(ray.get(ref))
            except ray.exceptions.RayError as exc:  # a node that just died gets no takes either
                log.warning(
                    "Ray node %s is gone (%s)", nodes[ref]["NodeID"][:8], type(exc).__name__
                )
    finally:
        probe.unlink(missing_ok=True)
    problems = [line for lines in answers for line in lines]
    if problems:
        raise InputError("\n".join(problems))


def memory_estimate_mb(
    *, duration_s: float, fps: float, width: int, height: int, decode_threads: int, config: Config
) -> float:
    """The module docstring's formula, in MB."""
    frames = max(duration_s, 0.0) * max(fps, 0.0)
    in_flight = width * height * 3 * (decode_threads + 2) / 1e6
    return (
        config.build.ray_memory_base_mb + frames * config.build.ray_memory_per_frame_kb / 1e3
    ) + in_flight


def chunk_memory_mb(job: ChunkJob, config: Config) -> float:
    """A chunk's memory estimate: its video's, for the chunk's duration."""
    from gesturebank.extract.video import probe

    try:
        info = probe(job.video)
    except Exception:  # the take's task will fail with the reason
        return config.build.ray_memory_base_mb
    end = job.range.end_s if job.range.end_s is not None else info.duration_s
    return memory_estimate_mb(
        duration_s=end - job.range.start_s if end == end else 0.0,  # NaN: unknown
        fps=info.fps,
        width=info.size[0],
        height=info.size[1],
        decode_threads=config.build.decode_threads or 1,
        config=config,
    )


def take_memory_mb(take: Take, config: Config) -> float:
    """A take's memory estimate from its videos' headers (the base alone for mocap)."""
    from gesturebank.extract.video import probe

    if take.mocap:
        return config.build.ray_memory_base_mb
    total = 0.0
    for video in take.videos or (take.video,):
        try:
            info = probe(video)
        except Exception:  # the task itself will fail with the reason
            return config.build.ray_memory_base_mb
        duration = info.duration_s if info.duration_s == info.duration_s else 0.0  # NaN: unknown
        total += memory_estimate_mb(
            duration_s=duration,
            fps=info.fps,
            width=info.size[0],
            height=info.size[1],
            decode_threads=config.build.decode_threads or 1,
            config=config,
        )
    return total


def task_cpus(config: Config) -> int:
    """The CPUs a take's task uses: decoding prefetches beside inference, but the detector's
    threads dominate, so the larger of the two thread counts."""
    return max(config.build.decode_threads or 1, config.build.inference_threads or 1)


def _largest(ray: Any, key: str) -> float:
    return max((n["Resources"].get(key, 0.0) for n in ray.nodes() if n["Alive"]), default=0.0)


def _clean_temporaries(out: Path, take_id: str) -> None:
    """What a killed attempt of this take left (no attempt of it runs any more)."""
    import shutil

    folder = Path(out) / store.TAKES_DIR
    for path in [*folder.glob(f".{take_id}.*.tmp"), *folder.glob(f".{take_id}.old")]:
        if path.is_dir():
            shutil.rmtree(path, ignore_errors=True)
        else:
            path.unlink(missing_ok=True)


def run_on_ray(
    schedule: Schedule, *, out: Path, videos_dir: Path, config: Config
) -> Generator[TakeResult, None, None]:
    """Every job as a Ray task sized for its take (or chunk); take results as they finish. A
    task whose worker or node died is retried by Ray (build.ray_max_retries), then its take is
    recorded failed with the reason (a lost chunk is detected by its take's task instead).
    Closing the generator (Ctrl-C) cancels what has not finished."""
    with connected(config.build.ray_address, config) as ray:
        check_storage(ray, out=out, videos_dir=videos_dir, config=config)
        cpus = task_cpus(config)
        most_cpus, most_memory_mb = _largest(ray, "CPU"), _largest(ray, "memory") / 1e6
        if cpus > most_cpus:
            raise InputError(
                f"build threads need {cpus} CPUs per take but the largest Ray node has "
                f"{most_cpus:g}: lower build.decode_threads / build.inference_threads"
            )
        log.info(
            "Ray: %d nodes, %g CPUs; %d CPU(s) per take",
            sum(n["Alive"] for n in ray.nodes()),
            ray.cluster_resources().get("CPU", 0),
            cpus,
        )
        remote_take, remote_chunk = ray.remote(run_take), ray.remote(run_chunk)
        refs: dict[Any, Job] = {}
        stamps = {take_id: record_stamp(out, take_id) for take_id in schedule.jobs}

        def submit(job: Job) -> Any:
            if isinstance(job, ChunkJob):
                take, _ = schedule.jobs[job.take_id]
                memory_mb = chunk_memory_mb(job, config)
            else:
                take, _ = job
                memory_mb = take_memory_mb(take, config)
            if most_memory_mb and memory_mb > most_memory_mb:
                log.warning("%s: needs ~%.0f MB, more than any node has", take.take_id, memory_mb)
                memory_mb = most_memory_mb
            options = dict(
                num_cpus=cpus,
                memory=int(memory_mb * 1e6),
                max_retries=config.build.ray_max_retries,
                retry_exceptions=False,  # neither raises: only lost workers are retried
            )
            if isinstance(job, ChunkJob):
                ref = remote_chunk.options(**options).remote(job, out=out, config=config)
            else:
                ref = remote_take.options(**options).remote(*job, out=out, config=config)
            refs[ref] = job
            return ref

        pending = [submit(job) for job in schedule.first()]
        try:
            while pending:
                done, pending = ray.wait(pending, num_returns=1)
                job = refs[done[0]]
                if isinstance(job, ChunkJob):
                    try:
                        ray.get(done[0])
                    except ray.exceptions.RayError as exc:  # its take detects it itself
                        log.info("%s: chunk lost (%s)", job.take_id, type(exc).__name__)
                    ready = schedule.chunk_done(job)
                    if ready is not None:
                        pending.append(submit(ready))
                    continue
                take, source = job
                try:
                    result = ray.get(done[0])
                except ray.exceptions.RayError as exc:
                    _clean_temporaries(out, take.take_id)
                    written = written_result(out, take.take_id)
                    if written and record_stamp(out, take.take_id) != stamps[take.take_id]:
                        yield written  # it died after writing the take whole, before replying
                        continue
                    tries = config.build.ray_max_retries + 1
                    reason = (
                        f"{take.video}: lost its Ray worker ({type(exc).__name__}) "
                        f"after {tries} attempt(s); run again to resume"
                    )
                    yield record_failure(take, source, out=out, config=config, reason=reason)
                    continue
                _clean_temporaries(out, take.take_id)  # a killed earlier attempt's
                yield result
        finally:
            _cancel(pending, timeout_s=config.build.ray_check_timeout_s)


# How long a stopped build waits for tasks whose replies are on their way before it cancels the
# rest, seconds: cancelling a task as its reply arrives races the reply in Ray's task manager,
# which aborts the driver (Ray 2.60: "Tried to complete task that was not pending"; the Ctrl-C
# lands just as a take is written, under load 1 in 3 times).
_REPLY_GRACE_S = 1.0


def _cancel(pending: list, *, timeout_s: float) -> None:
    """Stop the tasks `pending` (Ctrl-C or an error: keep what finished, and what is finishing)
    and let them end, up to `timeout_s`, before the caller removes what they left half-written."""
    import ray

    if not pending:
        return
    _, pending = ray.wait(pending, num_returns=len(pending), timeout=_REPLY_GRACE_S)
    for ref in pending:
        ray.cancel(ref, force=True)
    if pending:
        ray.wait(pending, num_returns=len(pending), timeout=timeout_s)
