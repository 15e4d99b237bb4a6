"""The run's report file and console lines."""
import os
import threading

from . import shared


class Report:
    """The report file, rewritten atomically after every file: files not done yet are "pending"."""

    def __init__(self, path, token, header, inputs, outputs):
        self.path, self.token, self.header, self.lock, self.problem = path, token, header, threading.Lock(), ""
        self.rows = [{"file": s, "output": d, "status": "pending", "error": "", "objects": [], "warnings": []}
                     for s, d in zip(inputs, outputs)]
        self.write()  # before any file: a report that cannot be written is a bad --report

    def write(self, complete=False):
        done = [r for r in self.rows if r["status"] != "pending"]
        failed = sum(r["status"] != "ok" for r in done)
        shared.write_json_atomically(self.path, {
            **self.header, "complete": complete, "ok": len(done) - failed, "failed": failed,
            "pending": len(self.rows) - len(done), "files": self.rows}, self.token)

    def record(self, i, row, complete=False):
        with self.lock:
            if row is not None:
                self.rows[i] = row
            try:
                self.write(complete)
                self.problem = ""
            except OSError as exc:  # e.g. the disk filled up: keep going, say so at the end
                self.problem = f"cannot write the report {self.path}: {exc.strerror or exc}"


def console_line(n, total, result):
    status = "ok" if result["status"] == "ok" else "FAILED: " + result["error"]
    warned = f", {len(result['warnings'])} warnings" if result.get("warnings") else ""
    return (f"[{n}/{total}] {os.path.basename(result['file'])}: {status} "
            f"({len(result['objects'])} objects, {result.get('seconds', 0.0):.2f} s{warned})")
