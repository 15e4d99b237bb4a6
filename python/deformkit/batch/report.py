"""The run's report file, console lines and (on a cluster) live progress line."""
import datetime
import os
import shutil
import sys
import threading

from . import shared


class Report:
    """The report file, rewritten atomically after every file: files not done yet are "pending"."""

    def __init__(self, path, token, header, inputs, outputs):
        self.path, self.token, self.header, self.lock, self.problem = path, token, header, threading.Lock(), ""
        self.rows = [shared.file_row(s, d, "pending") for s, d in zip(inputs, outputs)]
        self.write()  # before any file: a report that cannot be written is a bad --report

    def write(self, complete=False):
        done = [r for r in self.rows if r["status"] != "pending"]
        failed = sum(r["status"] != "ok" for r in done)
        shared.write_json_atomically(self.path, {
            **self.header, "complete": complete, "ok": len(done) - failed, "failed": failed,
            "pending": len(self.rows) - len(done), "files": self.rows}, self.token)

    def finish(self):
        """The run is over: the report gets its end time and is marked complete."""
        self.header["finished"] = utc_now()
        self.record(0, None, complete=True)

    def record(self, i, row, complete=False):
        with self.lock:
            if row is not None:
                self.rows[i] = row
            try:
                self.write(complete)
                self.problem = ""
            except OSError as exc:  # e.g. the disk filled up: keep going, say so at the end
                self.problem = f"cannot write the report {self.path}: {exc.strerror or exc}"


def utc_now():
    return datetime.datetime.now(datetime.timezone.utc).isoformat(timespec="seconds")


def console_line(n, total, result):
    status = "ok" if result["status"] == "ok" else "FAILED: " + result["error"]
    warned = f", {len(result['warnings'])} warnings" if result.get("warnings") else ""
    return (f"[{n}/{total}] {os.path.basename(result['file'])}: {status} "
            f"({len(result['objects'])} objects, {result.get('seconds', 0.0):.2f} s{warned})")


class Progress:
    """A cluster run's live progress: files done / failed / running of the total, and per worker
    files done and running. Attempts start and end as the workers announce them (Dask's event
    topic of the run); rows come as files finish. On a terminal the line is redrawn in place,
    elsewhere it is printed when a file finishes."""

    SHOWN_WORKERS = 8  # the busiest; the line says how many more

    def __init__(self, names, stream=None):
        self.names, self.total = list(names), len(names)
        self.stream, self.lock = stream or sys.stdout, threading.Lock()
        self.done, self.failed, self.running, self.per_worker = 0, 0, {}, {}
        self.tty = hasattr(self.stream, "isatty") and self.stream.isatty()

    def line(self):
        running = {w: sum(v == w for v in self.running.values()) for w in set(self.running.values())}
        workers = sorted(set(self.per_worker) | set(running))
        busiest = sorted(workers, key=lambda w: (-running.get(w, 0), -self.per_worker.get(w, 0), w))
        shown = sorted(busiest[:self.SHOWN_WORKERS])
        parts = [f"{w}: {self.per_worker.get(w, 0)} done, {running.get(w, 0)} running" for w in shown]
        if len(workers) > len(shown):
            parts.append(f"{len(workers) - len(shown)} more workers")
        head = f"progress: {self.done}/{self.total} done ({self.failed} failed), {len(self.running)} running"
        return "; ".join([head] + parts)

    def _show(self, text=None):
        if self.tty:  # the line redrawn in place must fit the terminal's width, or it scrolls
            width = shutil.get_terminal_size().columns - 1
            self.stream.write("\r\033[K" + (text + "\n" if text else "") + self.line()[:width])
        else:
            self.stream.write((text + "\n" if text else "") + self.line() + "\n")
        self.stream.flush()

    def event(self, message):
        """A worker's announcement: {"event": "start" or "end", "index", "attempt", "worker"}."""
        with self.lock:
            key = message.get("index")
            if message.get("event") == "start":
                self.running[key] = message.get("worker")
                if self.tty or (message.get("attempt") or 1) > 1:
                    name = self.names[key] if isinstance(key, int) and 0 <= key < self.total else key
                    self._show(f"{name}: attempt {message.get('attempt')} on {message.get('worker')}"
                               if (message.get("attempt") or 1) > 1 else None)
            elif message.get("event") == "end" and self.running.get(key) == message.get("worker"):
                del self.running[key]

    def finished(self, index, text, row):
        with self.lock:
            self.running.pop(index, None)
            self.done += 1
            self.failed += row["status"] != "ok"
            worker = row.get("worker")
            if worker:
                self.per_worker[worker] = self.per_worker.get(worker, 0) + 1
            self._show(text)

    def close(self):
        if self.tty:
            with self.lock:
                self.stream.write("\n")
                self.stream.flush()
