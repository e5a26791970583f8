"""Backends: local processes and a real Dask cluster give the serial table, bit for bit."""

from __future__ import annotations

import gc

import numpy as np
import pytest
from study_cases import hanging_problem, tables_equal

from dloplan.study import (
    DaskBackend,
    ProcessBackend,
    SerialBackend,
    make_backend,
    map_jobs,
    run_study,
)

# its module-scoped fixtures are computed once, on one worker (make test: --dist loadgroup)
pytestmark = pytest.mark.xdist_group("test_study_backends")

PROBLEM = hanging_problem(obstacles=True)
STUDY = {"samples": 24, "chunk_size": 4, "seed": 5,
         "parameters": {"youngs_modulus": {"spread": 30}, "length": {"spread": 1},
                        "clip_position": {"spread": 1}, "clip_orientation": {"spread": 2},
                        "obstacle_position": {"spread": 5}}}


@pytest.fixture(scope="module")
def serial_table():
    return run_study(PROBLEM, STUDY).table


def _scaled(shared, item):
    return shared * item


def test_map_jobs_yields_every_position_once():
    with ProcessBackend(2, max_in_flight=3) as backend:
        got = dict(map_jobs(_scaled, range(10), backend, shared=3))
    assert got == {k: 3 * k for k in range(10)}
    assert dict(map_jobs(_scaled, [], SerialBackend(), shared=3)) == {}


def _frozen(shared, item):
    return gc.get_freeze_count()


def test_a_local_worker_keeps_what_it_starts_with_out_of_the_collectors_scans():
    # the server's preloaded modules and the map's shared object: frozen (gc.freeze) when the
    # worker starts, so that a full collection during the tasks does not scan them
    with ProcessBackend(2, max_in_flight=1) as backend:
        counts = dict(map_jobs(_frozen, range(4), backend, shared=[object()]))
    assert min(counts.values()) > 10_000


def test_local_processes_give_the_serial_table(serial_table, tmp_path):
    with ProcessBackend(2) as backend:
        result = run_study(PROBLEM, STUDY, backend=backend, out=tmp_path)
    assert result.backend == "2 local processes"
    assert tables_equal(result.table, serial_table)


def test_dask_local_cluster_gives_the_serial_table(serial_table):
    distributed = pytest.importorskip("dask.distributed")
    with distributed.LocalCluster(n_workers=2, processes=True, threads_per_worker=1,
                                  dashboard_address=None) as cluster, \
            distributed.Client(cluster) as client:
        backend = DaskBackend(client=client, max_in_flight=3)
        result = run_study(PROBLEM, STUDY, backend=backend)
        assert tables_equal(result.table, serial_table)
        # by address, as ``--scheduler tcp://HOST:PORT`` does; the backend closes its client
        with make_backend(scheduler=cluster.scheduler_address) as by_address:
            assert by_address.workers == 2
            got = dict(map_jobs(_scaled, range(5), by_address, shared=np.float64(2.0)))
        assert got == {k: 2.0 * k for k in range(5)}


def test_backend_arguments_are_checked():
    assert isinstance(make_backend(workers=1), SerialBackend)
    assert isinstance(make_backend(workers=2), ProcessBackend)
    with pytest.raises(ValueError, match="workers: got 0"):
        ProcessBackend(0)
    with pytest.raises(ValueError, match="workers: not used with a Dask scheduler"):
        make_backend(workers=2, scheduler="tcp://127.0.0.1:1")
    with pytest.raises(ValueError, match="scheduler: got 'localhost'"):
        DaskBackend(scheduler="localhost")
    with pytest.raises(ValueError, match="exactly one of client or scheduler"):
        DaskBackend()


def test_an_address_that_answers_but_is_no_dask_scheduler_is_refused_in_one_line():
    """`study --scheduler` to a port where another service answers: Dask's handshake read
    the reply's first bytes as a frame length and raised MemoryError ("Unable to allocate 3.07
    EiB", a web server), struct.error or AssertionError (a port closed at once): a traceback,
    exit 1. It is now one line naming the address and what was expected (exit 2)."""
    import socket
    import threading

    server = socket.socket()
    server.bind(("127.0.0.1", 0))
    server.listen(1)

    def answer():
        connection, _ = server.accept()
        with connection:  # frames of lengths that do not add up, then wait for the client
            connection.sendall(b"\x01\x00\x00\x00\x00\x00\x00\x00" * 4)
            connection.settimeout(30)
            while connection.recv(1024):
                pass

    thread = threading.Thread(target=answer, daemon=True)
    thread.start()
    address = f"tcp://127.0.0.1:{server.getsockname()[1]}"
    try:
        with pytest.raises(ValueError, match=f"scheduler: {address} answered, but not as a "
                           "Dask scheduler .*expected the address of a running Dask"):
            make_backend(scheduler=address)
    finally:
        thread.join(5)
        server.close()
