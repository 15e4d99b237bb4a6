"""A Dask cluster's certificates made as docs/batch.md tells users to make them, with Debian's
openssl: the cluster's own CA, then a key and a certificate it signs for the scheduler, the
workers and the launcher (client); and a "rogue" CA with a client certificate of its own, which
the cluster must refuse. EC P-256 keys: made at once, unlike RSA ones.

    files = make_certificates(tmp_path / "tls")  # {"ca", "scheduler", "scheduler_key", ...}
"""
import pathlib
import subprocess

KEY = ["-newkey", "ec", "-pkeyopt", "ec_paramgen_curve:prime256v1", "-nodes"]


def openssl(*args, cwd):
    subprocess.run(["openssl", *map(str, args)], cwd=cwd, check=True, capture_output=True, timeout=60)


def make_ca(folder, name):
    openssl("req", "-x509", *KEY, "-days", "2", "-subj", f"/CN={name}", "-keyout", f"{name}.key",
            "-out", f"{name}.pem", cwd=folder)


def make_signed(folder, name, ca):
    openssl("req", *KEY, "-subj", f"/CN={name}", "-keyout", f"{name}.key", "-out", f"{name}.csr", cwd=folder)
    openssl("x509", "-req", "-in", f"{name}.csr", "-CA", f"{ca}.pem", "-CAkey", f"{ca}.key", "-CAcreateserial",
            "-days", "2", "-out", f"{name}.pem", cwd=folder)


def make_certificates(folder):
    folder = pathlib.Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    make_ca(folder, "ca")
    for role in ("scheduler", "worker", "client"):
        make_signed(folder, role, "ca")
    make_ca(folder, "rogue_ca")
    make_signed(folder, "rogue", "rogue_ca")
    files = {"ca": folder / "ca.pem"}
    for role in ("scheduler", "worker", "client", "rogue"):
        files[role], files[role + "_key"] = folder / f"{role}.pem", folder / f"{role}.key"
    return files
