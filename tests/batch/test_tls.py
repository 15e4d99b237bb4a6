"""Who the cluster lets in (docs/batch.md, "TLS: more than one machine"): a run over tls:// with
the cluster's CA and the launcher's certificate (on the command line, or in Dask's configuration)
succeeds; a client without a certificate the cluster's CA signed is refused by the scheduler
itself, in the TLS handshake; the launcher's TLS options are checked before anything runs; a plain
tcp:// scheduler off the loopback gets one warning line; the HTTP servers (dashboard, /health) of
a LocalCluster and of the test cluster listen on the loopback only. The certificates are made with
openssl exactly as the docs show (tests/support/tls_certificates.py), the cluster is `dask
scheduler` and `dask worker` processes started with the docs' TLS options
(tests/support/dask_cluster.py), Blender the fake one."""
import ipaddress
import json
import os
import pathlib
import socket
import ssl
import subprocess
import sys

import psutil
import pytest

from deformkit.batch import cluster_cli
from deformkit.batch.cluster import Cluster
from support.dask_cluster import DaskCluster, fake_inputs as inputs
from support.tls_certificates import make_certificates

REPO = pathlib.Path(__file__).resolve().parents[2]
ADDON = str(REPO / "python_addon")
GUARD_SECONDS = 180  # every command runs under it: a hang fails instead of blocking the suite


@pytest.fixture(scope="module")
def certificates(tmp_path_factory):
    return make_certificates(tmp_path_factory.mktemp("tls"))


@pytest.fixture(scope="module")
def tls_cluster(certificates, tmp_path_factory):
    with DaskCluster(tmp_path_factory.mktemp("cluster"), workers=1, tls=certificates) as running:
        yield running


def batch(blender, paths, out, *options, env=None):
    command = [sys.executable, "-m", "deformkit.batch", "--addon", ADDON, "--blender", blender, *map(str, paths),
               "--evaluate-saved", "--out", str(out), *map(str, options)]
    environ = {k: v for k, v in os.environ.items() if not k.startswith("DASK_")}
    return subprocess.run(command, capture_output=True, text=True, timeout=GUARD_SECONDS, stdin=subprocess.DEVNULL,
                          env={**environ, **(env or {})})


def tls_options(files, client="client"):
    return ["--tls-ca-file", files["ca"], "--tls-cert", files[client], "--tls-key", files[client + "_key"]]


def assert_one_line_error(proc, start):
    assert proc.returncode == 2, proc.stdout + proc.stderr
    assert proc.stderr.startswith(f"deformkit-batch: error: {start}"), proc.stderr
    assert proc.stderr.count("\n") == 1 and "Traceback" not in proc.stderr, proc.stderr


def test_a_run_succeeds_over_tls_with_options_or_dasks_configuration(tls_cluster, certificates, fake_blender,
                                                                       tmp_path):
    assert tls_cluster.address.startswith("tls://127.0.0.1:")
    paths = inputs(tmp_path / "in", ["ok", "fail", "ok"])
    config = {"DASK_DISTRIBUTED__COMM__TLS__CA_FILE": str(certificates["ca"]),
              "DASK_DISTRIBUTED__COMM__TLS__CLIENT__CERT": str(certificates["client"]),
              "DASK_DISTRIBUTED__COMM__TLS__CLIENT__KEY": str(certificates["client_key"])}
    for out, options, env in ((tmp_path / "options", tls_options(certificates), None),
                              (tmp_path / "config", [], config)):
        proc = batch(fake_blender, paths, out, "--scheduler", tls_cluster.address, *options, env=env)
        assert proc.returncode == 1, proc.stdout + proc.stderr + tls_cluster.logs()
        assert "warning" not in proc.stderr, proc.stderr
        report = json.loads((out / "report.json").read_text())
        assert report["complete"] and report["executor"]["scheduler"] == tls_cluster.address
        assert [r["status"] for r in report["files"]] == ["ok", "failed", "ok"]
        assert (out / "0_ok.blend").read_bytes() == b"BLENDER output of 0_ok.blend"


def refusal(address, certificates, client):
    """The TLS alert the scheduler ends a raw connection with, made as `client` (None: with no
    certificate). With TLS 1.3 the server's verdict on the client's certificate arrives after the
    client's side of the handshake, so the first read is what shows it: it blocks until the
    scheduler answers (GUARD_SECONDS only keeps a regression from hanging the suite)."""
    host, port = address[len("tls://"):].rsplit(":", 1)
    context = ssl.create_default_context(ssl.Purpose.SERVER_AUTH, cafile=str(certificates["ca"]))
    context.check_hostname = False  # Dask's own choice: a cluster's CA, addresses rather than names
    if client is not None:
        context.load_cert_chain(str(certificates[client]), str(certificates[client + "_key"]))
    with socket.create_connection((host, int(port)), timeout=GUARD_SECONDS) as raw:
        try:
            with context.wrap_socket(raw) as tls:
                return f"the scheduler let the client in, then sent {tls.recv(1)!r}"
        except ssl.SSLError as exc:
            return exc.reason


def identity(address, security):
    """The scheduler's answer to Dask's `identity` request, over a comm made with `security`."""
    import asyncio

    import distributed.comm

    async def ask():
        comm = await distributed.comm.connect(address, timeout=GUARD_SECONDS,
                                              **security.get_connection_args("client"))
        try:
            await comm.write({"op": "identity", "reply": True})
            return await comm.read()
        finally:
            await comm.close()
    return asyncio.run(ask())


def test_the_scheduler_refuses_a_client_without_the_clusters_certificate(tls_cluster, certificates,
                                                                          fake_blender, tmp_path):
    assert identity(tls_cluster.address, tls_cluster.security())["type"] == "Scheduler"  # the control
    assert refusal(tls_cluster.address, certificates, None) == "TLSV13_ALERT_CERTIFICATE_REQUIRED"
    assert refusal(tls_cluster.address, certificates, "rogue") == "TLSV1_ALERT_UNKNOWN_CA"
    paths = inputs(tmp_path / "in", ["ok"])
    rogue = batch(fake_blender, paths, tmp_path / "rogue", "--scheduler", tls_cluster.address,
                  *tls_options(certificates, "rogue"), "--connect-timeout", 3)
    assert_one_line_error(rogue, f"--scheduler: cannot reach the Dask scheduler {tls_cluster.address} within 3 s")
    assert "is --tls-cert signed by the CA the scheduler trusts" in rogue.stderr
    plain = batch(fake_blender, paths, tmp_path / "plain", "--scheduler",
                  tls_cluster.address.replace("tls://", "tcp://"), "--connect-timeout", 3)
    assert_one_line_error(plain, "--scheduler: cannot reach the Dask scheduler tcp://127.0.0.1:")
    assert not (tmp_path / "rogue" / "0_ok.blend").exists() and not (tmp_path / "plain" / "0_ok.blend").exists()
    assert tls_cluster.client().run(os.getpid)  # the cluster still serves the launcher's certificate


def test_tls_options_are_checked_before_anything_runs(certificates, fake_blender, tmp_path):
    paths = inputs(tmp_path / "in", ["ok"])
    out = tmp_path / "out"
    fifo = tmp_path / "ca.pem"
    os.mkfifo(fifo)
    (tmp_path / "notes.pem").write_text("not a certificate\n")
    address = "tls://127.0.0.1:9"  # nothing is contacted: every case fails before
    cases = [
        (["--scheduler", address, "--tls-ca-file", certificates["ca"]], "--tls-cert: missing"),
        (["--scheduler", "tcp://127.0.0.1:9", *tls_options(certificates)],
         "--tls-ca-file: only with a tls:// --scheduler"),
        (["--executor", "dask-local", "--tls-cert", certificates["client"]], "--tls-cert: only with a tls://"),
        (["--scheduler", address], f"--scheduler: {address} is TLS: give the cluster's CA"),
        (["--scheduler", address, "--tls-ca-file", fifo, "--tls-cert", certificates["client"]],
         f"--tls-ca-file: {fifo} is a FIFO (named pipe), not a regular file"),
        (["--scheduler", address, "--tls-ca-file", tmp_path / "notes.pem", "--tls-cert", certificates["client"]],
         f"--tls-ca-file: {tmp_path / 'notes.pem'} is not a PEM CA certificate"),
        (["--scheduler", address, "--tls-ca-file", certificates["ca"], "--tls-cert", certificates["client"],
          "--tls-key", certificates["rogue_key"]], f"--tls-cert: {certificates['client']} is not a PEM certificate "
                                                   f"with its private key {certificates['rogue_key']}"),
    ]
    for options, message in cases:
        proc = batch(fake_blender, paths, out, *options)
        assert_one_line_error(proc, message)
        assert not (out / "0_ok.blend").exists()
    config = {"DASK_DISTRIBUTED__COMM__TLS__CA_FILE": str(fifo),
              "DASK_DISTRIBUTED__COMM__TLS__CLIENT__CERT": str(certificates["client"])}
    proc = batch(fake_blender, paths, out, "--scheduler", address, env=config)
    assert_one_line_error(proc, f"distributed.comm.tls.ca-file: {fifo} is a FIFO (named pipe)")


@pytest.mark.parametrize("address, loopback", [
    ("tcp://127.0.0.1:8786", True), ("tcp://127.8.9.10:8786", True), ("tcp://localhost:8786", True),
    ("tcp://10.0.0.7:8786", False), ("tcp://192.0.2.1:8786", False), ("tcp://no-such-host.invalid:8786", False),
])
def test_which_scheduler_addresses_are_on_the_loopback(address, loopback):
    assert cluster_cli.on_loopback(address) is loopback
    assert (cluster_cli.plain_tcp_warning(address) is None) is loopback
    assert cluster_cli.plain_tcp_warning(address.replace("tcp://", "tls://")) is None  # TLS: no warning


def test_a_plain_tcp_scheduler_off_the_loopback_gets_one_warning_line(fake_blender, tmp_path):
    """192.0.2.1 (TEST-NET-1) answers nobody: the warning comes first, then the one-line error."""
    paths = inputs(tmp_path / "in", ["ok"])
    proc = batch(fake_blender, paths, tmp_path / "out", "--scheduler", "tcp://192.0.2.1:8786", "--connect-timeout", 1)
    warning, error = proc.stderr.splitlines()
    assert warning == ("deformkit-batch: warning: --scheduler tcp://192.0.2.1:8786 is plain tcp:// off this "
                       "machine: whoever can reach it can run code on every worker; use tls:// with --tls-ca-file, "
                       "--tls-cert and --tls-key (docs/batch.md)")
    assert proc.returncode == 2 and error.startswith("deformkit-batch: error: --scheduler: cannot reach")


def listening(pids):
    """The addresses the processes `pids` listen on (TCP), by the operating system's account."""
    found = set()
    for pid in pids:
        for conn in psutil.Process(pid).net_connections(kind="inet"):
            if conn.status == psutil.CONN_LISTEN:
                found.add(conn.laddr)
    return found


def off_loopback(addresses):
    return sorted(a for a in addresses if not ipaddress.ip_address(a.ip.split("%")[0]).is_loopback)


def test_a_local_clusters_servers_listen_on_the_loopback_only():
    before = listening([os.getpid()])
    cluster = Cluster.start_local(1, 1)
    try:
        me = psutil.Process()
        opened = listening([me.pid, *(c.pid for c in me.children(recursive=True))]) - before
        http = cluster.client.run_on_scheduler(lambda dask_scheduler: dask_scheduler.http_server.port)
        assert http in {a.port for a in opened}  # the scheduler's HTTP server is among them
        assert off_loopback(opened) == []
    finally:
        cluster.close()


def test_the_test_clusters_servers_listen_on_the_loopback_only(tls_cluster):
    pids = [p.pid for p in tls_cluster.processes]
    assert off_loopback(listening(pids)) == [] and listening(pids)
