"""Backends: the same jobs give the same rows in this process, in a process pool and on Ray
(and, once complete, the same results.csv bytes); a Ray address that does not answer fails
fast with one line."""

from __future__ import annotations

import csv
import shutil
import signal
import socket
import subprocess
import sys
import threading
import time
from collections.abc import Callable
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path
from typing import Any

import pytest

from d3dwa_bullet.backends import probe_address, split_address
from d3dwa_bullet.cli.app import main
from d3dwa_bullet.errors import BackendError
from d3dwa_bullet.evaluation import jobs as jobs_module
from d3dwa_bullet.evaluation.jobs import Job, evaluate, noise_config_json
from d3dwa_bullet.sim.noise_config import LidarNoiseConfig, NoiseConfig, SlipConfig
from d3dwa_bullet.world.model import Cylinder, World

TINY = World(
    "tiny", "a post beside the way", (0.0, 0.0, 0.0), (1.6, 0.0),
    (Cylinder((0.8, 0.35), 0.1),), time_limit=1.2,
)  # fmt: skip
NOISY = NoiseConfig(lidar=LidarNoiseConfig(range_std=0.03), slip=SlipConfig(0.1, 0.05, 0.02))


def jobs() -> list[Job]:
    """Four short episodes whose outcome depends on the seed (noise on)."""
    cfg = noise_config_json(NOISY)
    return [
        Job(TINY, m, s, "mix", noise_config=cfg, columns=(("tag", "x"),))
        for m in ("dwa1", "dwa3") for s in (0, 1)
    ]  # fmt: skip


def rows(out) -> list[tuple]:
    with (out / "results.csv").open() as fh:
        return sorted(tuple(r.values()) for r in csv.DictReader(fh))


FIELDS = ("world", "method", "policy_seed", "seed", "noise", "tag", "outcome", "time_s", "tl_m", "pd_rad",
          "min_clearance_m", "steps")  # fmt: skip


def within(seconds: float, fn: Callable[..., Any], *args: Any) -> Any:
    """fn(*args) in a thread; fails the test if it has not returned after seconds (a hang)."""
    pool = ThreadPoolExecutor(max_workers=1)
    try:
        return pool.submit(fn, *args).result(timeout=seconds)
    finally:
        pool.shutdown(wait=False)


@pytest.fixture(scope="module")
def in_process_dir(tmp_path_factory):
    out = tmp_path_factory.mktemp("w1")
    evaluate(jobs(), out, workers=1, progress=False, fields=FIELDS)
    return out


@pytest.fixture(scope="module")
def in_process(in_process_dir):
    return rows(in_process_dir)


def test_seeds_matter_so_the_comparison_means_something(in_process):
    assert len(in_process) == 4
    by_seed = {r[3]: r[7:] for r in in_process if r[1] == "dwa1"}
    assert by_seed["0"] != by_seed["1"]


def test_complete_results_are_the_same_bytes_with_any_number_of_workers(in_process_dir, tmp_path):
    """Two workers finish episodes in either order; the completed file is in job order."""
    returned = evaluate(jobs(), tmp_path, workers=2, progress=False, fields=FIELDS)
    data = (tmp_path / "results.csv").read_bytes()
    assert data == (in_process_dir / "results.csv").read_bytes()
    order = [(j.method, str(j.seed)) for j in jobs()]
    with (tmp_path / "results.csv").open(newline="") as fh:
        assert [(r["method"], r["seed"]) for r in csv.DictReader(fh)] == order
    assert [(r["method"], str(r["seed"])) for r in returned] == order


def test_rows_appended_in_any_order_are_put_in_job_order_when_complete(in_process_dir, tmp_path):
    """As if the episodes had finished last first: resuming the complete run reorders them."""
    lines = (in_process_dir / "results.csv").read_bytes().splitlines(keepends=True)
    (tmp_path / "results.csv").write_bytes(b"".join([lines[0], *reversed(lines[1:])]))
    shutil.copy(in_process_dir / "meta.json", tmp_path / "meta.json")
    evaluate(jobs(), tmp_path, workers=1, progress=False, fields=FIELDS)
    assert (tmp_path / "results.csv").read_bytes() == b"".join(lines)


def test_an_interrupted_run_keeps_every_row_in_the_order_they_finished(
    in_process_dir, tmp_path, monkeypatch
):
    lines = (in_process_dir / "results.csv").read_bytes().splitlines(keepends=True)
    finished = b"".join([lines[0], lines[2], lines[1]])  # jobs 1 and 0 finished, in that order
    (tmp_path / "results.csv").write_bytes(finished)
    shutil.copy(in_process_dir / "meta.json", tmp_path / "meta.json")

    def interrupted(job, config):
        raise KeyboardInterrupt

    monkeypatch.setattr(jobs_module, "run_job", interrupted)
    with pytest.raises(KeyboardInterrupt):
        evaluate(jobs(), tmp_path, workers=1, progress=False, fields=FIELDS)
    assert (tmp_path / "results.csv").read_bytes() == finished


@pytest.mark.slow
def test_ray_gives_identical_rows(in_process, tmp_path):
    """Starts a private local Ray instance (ray.init(num_cpus=1)): 15-40 s on a busy machine."""
    ray = pytest.importorskip("ray", reason="ray is not installed (pip install '.[ray]')")
    try:
        evaluate(jobs(), tmp_path, workers=1, progress=False, fields=FIELDS, ray_address="local")
    finally:
        if ray.is_initialized():
            ray.shutdown()
    assert rows(tmp_path) == in_process
    assert not ray.is_initialized()  # the session evaluate started is shut down


@pytest.mark.slow
def test_ray_cluster_address_gives_identical_rows(in_process, tmp_path):
    """A real cluster: `ray start --head --block` on a free 127.0.0.1 port, joined by
    HOST:PORT, then stopped by terminating that one process (it stops its own children)."""
    ray = pytest.importorskip("ray", reason="ray is not installed (pip install '.[ray]')")
    exe = shutil.which("ray") or str(Path(sys.executable).with_name("ray"))
    port = free_port()
    head = subprocess.Popen(
        [exe, "start", "--head", "--block", f"--port={port}", "--node-ip-address=127.0.0.1",
         "--num-cpus=1", "--include-dashboard=false", "--disable-usage-stats"],
        stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL,
    )  # fmt: skip
    try:
        deadline = time.monotonic() + 120
        while True:
            try:
                probe_address(f"127.0.0.1:{port}", timeout=1.0)
                break
            except BackendError:
                if time.monotonic() > deadline or head.poll() is not None:
                    pytest.fail("`ray start --head` did not come up within 120 s")
                time.sleep(1.0)
        evaluate(jobs(), tmp_path, progress=False, fields=FIELDS, ray_address=f"127.0.0.1:{port}")
        assert rows(tmp_path) == in_process
        assert not ray.is_initialized()
    finally:
        head.send_signal(signal.SIGTERM)
        try:
            head.wait(timeout=60)
        except subprocess.TimeoutExpired:
            head.kill()
        # `ray start` records its address for `auto`; do not leave a dead one behind.
        marker = Path("/tmp/ray/ray_current_cluster")
        if marker.exists() and marker.read_text().strip().endswith(f":{port}"):
            marker.unlink()


@pytest.mark.parametrize(
    ("address", "expected"),
    [
        ("127.0.0.1:6379", ("127.0.0.1", 6379, False)),
        ("ray://head.lan:10001", ("head.lan", 10001, True)),
        ("ray://head.lan", ("head.lan", 10001, True)),
        ("[::1]:6379", ("::1", 6379, False)),
    ],
)
def test_split_address(address, expected):
    assert split_address(address) == expected


@pytest.mark.parametrize("address", ["head.lan", "head:port", "h:0", ":6379", "h:70000"])
def test_split_address_refuses_malformed(address):
    with pytest.raises(BackendError, match="not 'local', 'auto'"):
        split_address(address)


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def test_probe_refuses_a_closed_port_quickly():
    pytest.importorskip("grpc", reason="grpcio comes with the ray extra")
    t0 = time.perf_counter()
    with pytest.raises(BackendError, match="does not answer"):
        probe_address(f"127.0.0.1:{free_port()}", timeout=1.0)
    assert time.perf_counter() - t0 < 3.0


def test_probe_refuses_an_open_port_that_is_not_ray():
    """A TCP server that is not gRPC (not a Ray GCS) must not pass for one."""
    pytest.importorskip("grpc", reason="grpcio comes with the ray extra")
    server = socket.socket()
    server.bind(("127.0.0.1", 0))
    server.listen()
    conns = []
    threading.Thread(target=lambda: conns.append(server.accept()), daemon=True).start()
    try:
        with pytest.raises(BackendError, match="does not answer"):
            probe_address(f"127.0.0.1:{server.getsockname()[1]}", timeout=0.5)
    finally:
        server.close()


def test_cli_with_a_silent_ray_address_exits_2_with_one_line(tmp_path, capsys):
    pytest.importorskip("ray", reason="ray is not installed")
    out = tmp_path / "res"
    args = ["eval", "--methods", "dwa1", "--worlds", "R1", "--out", str(out),
            "--ray", f"127.0.0.1:{free_port()}"]  # fmt: skip
    assert within(60.0, main, args) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith("d3dwa: error: Ray address") and "\n" not in err
    assert not (out / "results.csv").exists()  # nothing half-started


def test_cli_with_a_malformed_ray_address(tmp_path, capsys):
    assert main(["sweep", "--methods", "dwa1", "--out", str(tmp_path), "--ray", "nohost"]) == 2
    assert "not 'local', 'auto'" in capsys.readouterr().err
