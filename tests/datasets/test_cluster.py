"""build-dataset on a real two-node Ray cluster on this machine, started as users start one
(`ray start`) or with Ray's own test cluster: connecting, the same dataset as the local pool, a
node lost mid-build, and an OUT_DIR one node does not share."""

import os
import shutil
import signal
import socket
import subprocess
import sys
import threading
import time
from collections.abc import Iterator
from pathlib import Path

import numpy as np
import pytest

from gesturebank.app.build import build_dataset
from gesturebank.app.cluster import connected, is_this_machine, memory_estimate_mb
from gesturebank.config import Config
from gesturebank.datasets import store
from gesturebank.datasets.takes import discover_takes
from gesturebank.errors import InputError
from tests.datasets.test_build import assert_same_dataset

ray = pytest.importorskip("ray")
pytestmark = pytest.mark.slow

BIN = Path(sys.executable).parent
NODE = ["--num-cpus=1", "--node-ip-address=127.0.0.1", "--disable-usage-stats", "--block"]
# A SIGTERM'd `ray start --block` first drains its node for Ray Serve, 30 s by default: nothing
# here serves, so the nodes stop at once.
NO_DRAIN = {"RAY_GRACEFUL_SHUTDOWN_DRAIN_TIMEOUT_S": "0"}


@pytest.fixture(autouse=True)
def _own_auth_mode(monkeypatch: pytest.MonkeyPatch) -> None:
    """Connecting to a local head may switch RAY_AUTH_MODE on in this process: undo it after."""
    monkeypatch.setenv("RAY_AUTH_MODE", os.environ.get("RAY_AUTH_MODE", ""))
    monkeypatch.delenv("RAY_AUTH_MODE")


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def _alive_nodes(address: str) -> int:
    with connected(address, Config()) as r:
        return sum(n["Alive"] for n in r.nodes())


class RayStart:
    """`ray start --block` processes (a head, then nodes), each in its own process group so
    that exactly these are stopped afterwards."""

    def __init__(self) -> None:
        self.port = _free_port()
        self.address = f"127.0.0.1:{self.port}"
        self.client_address = f"ray://127.0.0.1:{_free_port()}"  # the head's Ray Client server
        self.procs: list[subprocess.Popen] = []

    def start(self, *prefix: str, head: bool = False) -> None:
        where = (
            [
                "--head",
                f"--port={self.port}",
                f"--ray-client-server-port={self.client_address.rpartition(':')[2]}",
                "--include-dashboard=false",
            ]
            if head
            else [f"--address={self.address}"]
        )
        cmd = [*prefix, str(BIN / "ray"), "start", *where, *NODE]
        self.procs.append(
            subprocess.Popen(
                cmd,
                stdout=subprocess.DEVNULL,
                stderr=subprocess.DEVNULL,
                start_new_session=True,
                env=os.environ | NO_DRAIN,
            )
        )
        wanted = len(self.procs)
        deadline = time.monotonic() + 120
        while time.monotonic() < deadline:
            try:
                if _alive_nodes(self.address) == wanted:
                    return
            except InputError:
                pass  # the head is not up yet
            time.sleep(1)
        raise AssertionError(f"ray start {' '.join(where)}: no node {wanted} within 120 s")

    def stop(self) -> None:
        for proc in reversed(self.procs):
            os.killpg(proc.pid, signal.SIGTERM)  # `ray start --block` stops its node's processes
        for proc in self.procs:
            proc.wait(timeout=60)


@pytest.fixture
def ray_start() -> Iterator[RayStart]:
    cluster = RayStart()
    try:
        yield cluster
    finally:
        cluster.stop()


def test_loopback_and_auto_give_the_pools_dataset(
    ray_start: RayStart, samples: Path, demo_dataset: Path, tmp_path: Path
) -> None:
    """As the issue tried it: a head bound to loopback, then the address given, `auto`, and
    the head's Ray Client server (ray://)."""
    assert is_this_machine("127.0.0.1") and is_this_machine("localhost")
    ray_start.start(head=True)
    ray_start.start()
    videos = samples / "talking"
    for address in (ray_start.address, "auto", ray_start.client_address):
        out = tmp_path / address.replace(":", "_").replace("/", "")
        cmd = [str(BIN / "build-dataset"), str(videos), str(out), "--executor", "ray"]
        r = subprocess.run(
            [*cmd, "--ray-address", address], capture_output=True, text=True, timeout=600
        )
        assert r.returncode == 0, r.stderr[-2000:]
        assert "3/3" in r.stdout and "skipped" in r.stdout  # the pool's progress and summary
        assert "lab__cam01_arctic: 1 of 1 clips kept" in r.stdout
        assert_same_dataset(out, demo_dataset)


def test_nothing_there_is_one_line(tmp_path: Path, samples: Path) -> None:
    port = _free_port()  # nothing listens on it
    r = subprocess.run(
        [
            str(BIN / "build-dataset"),
            str(samples / "talking"),
            str(tmp_path / "out"),
            "--executor=ray",
            f"--ray-address=127.0.0.1:{port}",
        ],
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert r.returncode == 2
    errors = [line for line in r.stderr.splitlines() if line.startswith("error:")]
    assert len(errors) == 1 and f"127.0.0.1:{port}" in errors[0], r.stderr
    assert "ray start --head" in errors[0]


def _unshared_node_possible() -> bool:
    return os.geteuid() == 0 and shutil.which("unshare") is not None


@pytest.mark.skipif(not _unshared_node_possible(), reason="needs root for unshare -m")
def test_out_dir_not_shared_with_a_node_is_one_line(
    ray_start: RayStart, samples: Path, tmp_path: Path
) -> None:
    """The second node runs in its own mount namespace where a tmpfs hides OUT_DIR, as a node
    would that has no share mounted there."""
    out = tmp_path / "out"
    out.mkdir()
    ray_start.start(head=True)
    hide = f'mount -t tmpfs none {out} && exec "$@"'
    ray_start.start("unshare", "-m", "sh", "-c", hide, "sh")
    r = subprocess.run(
        [
            str(BIN / "build-dataset"),
            str(samples / "talking"),
            str(out),
            "--executor=ray",
            f"--ray-address={ray_start.address}",
        ],
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert r.returncode == 2, r.stderr[-2000:]
    errors = [line for line in r.stderr.splitlines() if "not shared" in line]
    assert len(errors) == 1, r.stderr[-2000:]  # the head shares it
    assert errors[0].startswith(f"error: OUT_DIR {out} is not shared with node ")
    assert errors[0].endswith("mount it at the same path")
    assert not list(out.glob("takes/*.json"))  # nothing was built
    assert not list(out.glob(".gesturebank-probe-*"))  # the probe is removed


def _running_a_take(raylet: int) -> list[int]:
    """The node's worker processes, when one of them runs a take (Ray titles it ray::run_take)."""
    ps = subprocess.run(["pgrep", "-P", str(raylet)], capture_output=True, text=True)
    pids = [int(p) for p in ps.stdout.split()]
    for pid in pids:
        try:
            if Path(f"/proc/{pid}/cmdline").read_bytes().startswith(b"ray::run_take"):
                return pids
        except OSError:
            pass
    return []


def _kill_node_mid_take(cluster: object, node: object, out: Path, killed: list[int]) -> None:
    """Once a take is written, SIGKILL the node's raylet and workers while it builds a take, as
    a machine going down."""
    raylet = node.all_processes["raylet"][0].process.pid  # type: ignore[attr-defined]
    deadline = time.monotonic() + 300
    while not list((out / "takes").glob("*.json")) and time.monotonic() < deadline:
        time.sleep(0.005)
    while not (workers := _running_a_take(raylet)) and time.monotonic() < deadline:
        time.sleep(0.005)
    for pid in [raylet, *workers]:
        os.kill(pid, signal.SIGKILL)
    killed += workers
    cluster.remove_node(node, allow_graceful=False)  # type: ignore[attr-defined]


@pytest.mark.parametrize("retries", [0, 2])
def test_a_node_lost_mid_build(
    retries: int, samples: Path, demo_dataset: Path, tmp_path: Path
) -> None:
    """Two one-CPU nodes; the second dies as the first take is written, while it builds another.
    Retried, its take is built on the head; not retried, it is failed with the reason and a rerun
    builds it. Nothing half-written is left either way."""
    from ray.cluster_utils import Cluster

    small = {"num_cpus": 1, "object_store_memory": 80 * 1024**2}
    cluster = Cluster(initialize_head=True, head_node_args=small)
    try:
        node = cluster.add_node(**small)
        cluster.wait_for_nodes()
        videos, out = samples / "talking", tmp_path / "out"
        config = Config.model_validate(
            {
                "build": {
                    "executor": "ray",
                    "ray_address": cluster.address,
                    "ray_max_retries": retries,
                }
            }
        )
        killed: list[int] = []
        killer = threading.Thread(target=_kill_node_mid_take, args=(cluster, node, out, killed))
        killer.start()
        summary = build_dataset(discover_takes(videos), videos_dir=videos, out=out, config=config)
        killer.join()
        assert killed, "the node should die while it builds a take"
        outcomes = {r.take_id: r for r in summary.results}
        assert len(outcomes) == 3
        lost = [r for r in summary.failed if "lost its Ray worker" in r.reason]
        if retries:
            assert summary.count("built") == 3, summary.failed
        else:
            assert len(lost) == 1 and summary.count("built") == 2, summary.results
            assert f"after {retries + 1} attempt(s)" in lost[0].reason
        assert not list((out / "takes").glob(".*"))  # no temporaries, no half-written take
        for npz in (out / "takes").glob("*/*.npz"):
            with np.load(npz, allow_pickle=False) as d:
                assert d["angles"].shape[1] == 11
        if not retries:
            again = build_dataset(discover_takes(videos), videos_dir=videos, out=out, config=config)
            assert again.count("skipped") == 2 and again.count("built") == 1
        assert store.read_record(out, lost[0].take_id if lost else "lab__cam01_arctic")
        assert_same_dataset(out, demo_dataset)
    finally:
        cluster.shutdown()


def test_memory_grows_with_duration_and_resolution() -> None:
    config = Config()
    base = config.build.ray_memory_base_mb
    short = memory_estimate_mb(
        duration_s=7.1, fps=60, width=1080, height=1920, decode_threads=1, config=config
    )
    assert base < short < base + 50
    hour = memory_estimate_mb(
        duration_s=3600, fps=60, width=1080, height=1920, decode_threads=1, config=config
    )
    uhd = memory_estimate_mb(
        duration_s=3600, fps=60, width=2160, height=3840, decode_threads=1, config=config
    )
    assert short < hour < uhd
    per_frame_mb = config.build.ray_memory_per_frame_kb / 1e3
    assert hour == pytest.approx(base + 3600 * 60 * per_frame_mb + 1080 * 1920 * 3 * 3 / 1e6)


def test_ctrl_c_cancels_the_tasks_keeps_finished_takes_and_a_rerun_resumes(
    samples: Path, tmp_path: Path
) -> None:
    from ray.cluster_utils import Cluster

    cluster = Cluster(
        initialize_head=True, head_node_args={"num_cpus": 1, "object_store_memory": 80 * 1024**2}
    )
    try:
        videos, out = samples / "talking", tmp_path / "out"
        cmd = [str(BIN / "build-dataset"), str(videos), str(out), "--executor", "ray"]
        cmd += ["--ray-address", cluster.address]
        # its own process group, as a terminal's Ctrl-C; the cluster's workers are not in it
        proc = subprocess.Popen(
            cmd,
            stdout=subprocess.PIPE,
            stderr=subprocess.DEVNULL,
            text=True,
            start_new_session=True,
        )
        deadline = time.monotonic() + 300
        while not list((out / "takes").glob("*.json")) and time.monotonic() < deadline:
            time.sleep(0.005)
        os.killpg(proc.pid, signal.SIGINT)
        stdout, _ = proc.communicate(timeout=120)
        assert proc.returncode == 130, stdout
        assert "interrupted" in stdout
        done = {p.stem for p in (out / "takes").glob("*.json")}
        assert 1 <= len(done) < 3, "the interrupt should land mid-build"
        with connected(cluster.address, Config()) as r:  # the cluster has no task left running
            assert r.available_resources().get("CPU") == 1.0
        assert {p.stem for p in (out / "takes").glob("*.json")} == done
        assert not list((out / "takes").glob(".*"))
        r = subprocess.run(cmd, capture_output=True, text=True, timeout=300)
        assert r.returncode == 0, r.stderr[-2000:]
        assert len(list((out / "takes").glob("*.json"))) == 3
    finally:
        cluster.shutdown()
