"""The command line's Dask side: the options of a run on a cluster, which combinations make sense,
TLS (tls:// with the cluster's CA and a client certificate, or Dask's own configuration) and the
warning for a plain tcp:// scheduler off this machine. The cluster itself is cluster.py's; the run
on it, places.DaskCluster. Dask is imported only through cluster.py, when a run asks for it."""
import argparse
import ipaddress
import re
import socket
import ssl

from . import shared
from .cluster import PINS, dask_installed, distributed_module


TLS_OPTIONS = ("tls_ca_file", "tls_cert", "tls_key")
PEM_LIMIT = 1024 * 1024  # bytes: a certificate chain or a key is a few KB


def scheduler_address(text):
    if not re.fullmatch(r"(tcp|tls)://[^\s/:]+:\d{1,5}", text):
        raise argparse.ArgumentTypeError(f"expected a scheduler address tcp://HOST:PORT, got {text!r} "
                                         "(or tls://HOST:PORT with TLS)")
    return text


def on_loopback(address):
    """True when every address the scheduler's host name stands for is this machine's loopback
    (127.0.0.0/8, ::1); a name that does not resolve is not."""
    host = address.split("://", 1)[-1].rsplit(":", 1)[0].strip("[]")
    try:
        return ipaddress.ip_address(host).is_loopback
    except ValueError:
        pass
    try:
        found = {info[4][0] for info in socket.getaddrinfo(host, None)}
    except (OSError, UnicodeError):
        return False
    return bool(found) and all(ipaddress.ip_address(a.split("%")[0]).is_loopback for a in found)


def plain_tcp_warning(address):
    """The one line printed for a tcp:// scheduler that is not on the loopback, else None."""
    if not address.startswith("tcp://") or on_loopback(address):
        return None
    return (f"deformkit-batch: warning: --scheduler {address} is plain tcp:// off this machine: whoever can reach "
            "it can run code on every worker; use tls:// with --tls-ca-file, --tls-cert and --tls-key "
            "(docs/batch.md)")


def count_of(what, least, most):
    def parse(text):
        try:
            value = int(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"expected a whole number of {what}, got {text!r}") from None
        if not least <= value <= most:
            raise argparse.ArgumentTypeError(f"expected {least}..{most} {what}, got {text!r}")
        return value
    return parse


def add_arguments(ap, seconds):
    dask = ap.add_argument_group("on a Dask cluster (docs/batch.md)")
    dask.add_argument("--scheduler", type=scheduler_address,
                      help="run every file as a task on the Dask scheduler at tcp://HOST:PORT")
    dask.add_argument("--executor", choices=("local", "dask-local"),
                      help="local: processes of this machine (the default); dask-local: a Dask LocalCluster")
    dask.add_argument("--workers", type=count_of("workers", 1, 256), help="dask-local: worker processes (default 2)")
    dask.add_argument("--blender-per-worker", type=count_of("Blenders per worker", 1, 64),
                      help="dask-local: files each worker runs at a time (threads and blender resource; default 1)")
    dask.add_argument("--retries", type=count_of("retries", 0, 100),
                      help="times a file is sent again when the worker running it dies (default 2)")
    dask.add_argument("--redo-complete", action="store_true",
                      help="redo a file an earlier attempt of this run had completed before its worker died")
    dask.add_argument("--connect-timeout", type=seconds,
                      help="seconds to reach the scheduler and for a worker to join (default 30)")
    dask.add_argument("--tls-ca-file", help="tls:// scheduler: the cluster's CA certificate (PEM), as given to "
                                            "`dask scheduler --tls-ca-file` and the workers")
    dask.add_argument("--tls-cert", help="tls:// scheduler: this launcher's certificate (PEM), signed by that CA")
    dask.add_argument("--tls-key", help="tls:// scheduler: the private key of --tls-cert (PEM), unless --tls-cert "
                                        "holds it")


DASK_ONLY = ("retries", "redo_complete")
LOCAL_CLUSTER_ONLY = ("workers", "blender_per_worker")


def option(name):
    return "--" + name.replace("_", "-")


def executor_kind(ap, args, client):
    """"local", "dask-local" or "dask" (a scheduler: --scheduler, or the client or address of the
    Python API), or a one-line error naming the argument that does not fit."""
    if client is not None and (args.scheduler or args.executor):
        ap.error(f"{'--scheduler' if args.scheduler else '--executor'}: the run already has a Dask client "
                 "(main(..., client=...)); give one or the other")
    if args.scheduler and args.executor:
        ap.error(f"--executor: {args.executor} cannot be combined with --scheduler (a scheduler's cluster runs "
                 "the files)")
    kind = "dask" if args.scheduler or client is not None else args.executor or "local"
    if kind != "local" and args.jobs is not None:
        ap.error("--jobs: for local processes only; on Dask each worker runs as many files as it has units of "
                 "the blender resource (--blender-per-worker with dask-local)")
    wrong = [n for n in DASK_ONLY if getattr(args, n) not in (None, False)] if kind == "local" else []
    wrong += [n for n in LOCAL_CLUSTER_ONLY if getattr(args, n) is not None] if kind != "dask-local" else []
    if wrong:
        where = "--executor dask-local" if wrong[0] in LOCAL_CLUSTER_ONLY else "--scheduler or --executor dask-local"
        ap.error(f"{option(wrong[0])}: only with {where}")
    if kind != "dask" and args.connect_timeout is not None:
        ap.error("--connect-timeout: only with --scheduler (a LocalCluster is started here)")
    given = [n for n in TLS_OPTIONS if getattr(args, n) is not None]
    if given and not (args.scheduler or (client if isinstance(client, str) else "")).startswith("tls://"):
        ap.error(f"{option(given[0])}: only with a tls:// --scheduler (a LocalCluster stays on 127.0.0.1; tcp:// is "
                 "not encrypted)")
    if kind != "local":
        if not dask_installed():
            ap.error(f"{'--executor dask-local' if kind == 'dask-local' else '--scheduler'}: needs dask and "
                     f"distributed, which are not installed here; install {PINS}")
    return kind


def pem_file(ap, name, path):
    """`path` checked as a PEM file can be: a regular file (after links) of at most PEM_LIMIT
    bytes, so that ssl never blocks on a FIFO nor reads a device; else one line naming `name`."""
    try:
        shared.read_regular_file(path, PEM_LIMIT)
    except shared.FileRefused as exc:
        ap.error(f"{name}: {path} {exc}")
    except OSError as exc:
        ap.error(f"{name}: cannot read {path}: {exc.strerror or exc}")
    return path


def tls_security(ap, args, address):
    """The distributed.Security for a tls:// scheduler: the command line's CA, certificate and
    key, or else Dask's configuration (distributed.comm.tls.ca-file, .client.cert, .client.key);
    checked here (files, PEM, key matching certificate), so that a mistake is one line naming
    the option rather than a failed handshake. None for tcp://."""
    if not address.startswith("tls://"):
        return None
    security = distributed_module().Security
    if any(getattr(args, n) is not None for n in TLS_OPTIONS):
        ca, cert, key = args.tls_ca_file, args.tls_cert, args.tls_key
        names = ("--tls-ca-file", "--tls-cert", "--tls-key")
        missing = [n for n, v in zip(names[:2], (ca, cert)) if v is None]
        if missing:
            ap.error(f"{missing[0]}: missing; a tls:// scheduler needs the cluster's CA (--tls-ca-file) and this "
                     "launcher's certificate (--tls-cert, with --tls-key unless the certificate file holds the key)")
    else:
        found = security()  # Dask's configuration, DASK_DISTRIBUTED__COMM__TLS__* included
        ca, cert, key = found.tls_ca_file, found.tls_client_cert, found.tls_client_key
        names = ("distributed.comm.tls.ca-file", "distributed.comm.tls.client.cert", "distributed.comm.tls.client.key")
        if ca is None or cert is None:
            ap.error(f"--scheduler: {address} is TLS: give the cluster's CA and this launcher's certificate and key "
                     "(--tls-ca-file, --tls-cert, --tls-key), or set distributed.comm.tls.ca-file, "
                     "distributed.comm.tls.client.cert and .key in Dask's configuration")
    for name, path in zip(names, (ca, cert, key)):
        if path is not None:
            pem_file(ap, name, path)
    context = ssl.create_default_context(ssl.Purpose.SERVER_AUTH)
    try:
        context.load_verify_locations(cafile=ca)
    except (ssl.SSLError, ValueError) as exc:
        ap.error(f"{names[0]}: {ca} is not a PEM CA certificate ({exc})")
    try:
        context.load_cert_chain(cert, key)
    except (ssl.SSLError, ValueError) as exc:
        ap.error(f"{names[1]}: {cert} is not a PEM certificate with its private key"
                 f"{f' {key}' if key else ''} ({exc})")
    return security(tls_ca_file=ca, tls_client_cert=cert, tls_client_key=key, require_encryption=True)
