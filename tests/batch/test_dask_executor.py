"""DaskExecutor's decisions when its scheduler goes away, driven step by step through a scripted
client (no cluster, no timing): a task that lands while the client has lost its scheduler is the
scheduler's loss, not a worker's, so it is not sent again (a resend would wait for a scheduler
that is gone until the client gives up); a closed client does not make shutdown raise. The real
cluster's side is test_dask.py::test_the_scheduler_dies_mid_run."""
import pytest

from deformkit.batch import attempts
from deformkit.batch.dask_executor import DaskExecutor


class CommClosedError(Exception):
    """Named as distributed's: what task.result() raises when the result died on its way."""


class ClosedClientError(Exception):
    pass


class ScriptedTask:
    def __init__(self, key):
        self.key, self.status, self.callbacks, self.error = key, "pending", [], None

    def add_done_callback(self, fn):
        self.callbacks.append(fn)

    def result(self):
        if self.error is not None:
            raise self.error
        return {"status": "ok", "error": ""}

    def land(self, status, error=None):
        self.status, self.error = status, error
        for fn in self.callbacks:
            fn(self)


class ScriptedClient:
    """What DaskExecutor uses of distributed.Client; `status` as distributed sets it: "running",
    then "connecting" once the scheduler's connection broke, then "closed"."""

    def __init__(self):
        self.status, self.tasks, self.topics = "running", [], set()

    def subscribe_topic(self, topic, handler):
        self.topics.add(topic)

    def unsubscribe_topic(self, topic):
        if self.status == "closed":
            raise ClosedClientError(f"Client is {self.status}. Can't send unsubscribe-topic message.")
        self.topics.discard(topic)

    def submit(self, fn, *args, key, **kwargs):
        self.tasks.append(ScriptedTask(key))
        return self.tasks[-1]


@pytest.fixture
def executor(tmp_path, make_job):
    client = ScriptedClient()
    plan = attempts.AttemptPlan(staging=str(tmp_path / "staging"), token="1-0123abcd", max_attempts=3)
    (tmp_path / "staging").mkdir()
    return DaskExecutor(client, plan), client, make_job("ok")


@pytest.mark.parametrize("status", ["connecting", "closed"])
def test_a_result_lost_with_the_scheduler_is_not_sent_again(executor, status):
    dask, client, job = executor
    future = dask.submit(lambda j: None, job)
    client.status = status
    client.tasks[0].land("error", CommClosedError("in <TCP (closed)>: Stream is closed"))
    assert len(client.tasks) == 1, "sent again to a scheduler that is gone"
    row = future.result(timeout=0)
    assert row["status"] == "failed" and row["error"].startswith(
        "SchedulerLost: the connection to the Dask scheduler was lost before the file was done"), row


def test_a_result_lost_with_its_worker_is_sent_again(executor):
    """The contrast: the scheduler still there, the same error is a worker's loss and the file
    gets another attempt, whose row the future then gets."""
    dask, client, job = executor
    future = dask.submit(lambda j: None, job)
    client.tasks[0].land("error", CommClosedError("in <TCP (closed)>: Stream is closed"))
    assert len(client.tasks) == 2 and not future.done()
    client.tasks[1].land("finished")
    assert future.result(timeout=0)["status"] == "ok"


def test_a_file_sent_while_the_scheduler_is_gone_is_reported_lost_at_once(executor):
    dask, client, job = executor
    client.status = "connecting"
    row = dask.submit(lambda j: None, job).result(timeout=0)
    assert client.tasks == [] and row["error"].startswith("SchedulerLost:"), row


def test_a_task_the_lost_connection_cancelled_is_scheduler_lost(executor):
    dask, client, job = executor
    future = dask.submit(lambda j: None, job)
    client.status = "connecting"
    client.tasks[0].land("cancelled")
    assert future.result(timeout=0)["error"].startswith("SchedulerLost:")


@pytest.mark.parametrize("status", ["running", "closed"])
def test_shutdown_after_the_files_whatever_the_client(executor, status):
    """The launcher's report is completed after shutdown: a client that closed after losing its
    scheduler must not turn the end of the run into a traceback (exit 1, report incomplete)."""
    dask, client, job = executor
    future = dask.submit(lambda j: None, job)
    client.tasks[0].land("finished")
    client.status = status
    dask.shutdown(wait=True)
    assert future.result(timeout=0)["status"] == "ok"
    assert client.topics == ({dask.topic} if status == "closed" else set())


def test_shutdown_still_raises_what_a_connected_client_refuses(executor):
    dask, client, job = executor

    def refuse(topic):
        raise ClosedClientError("refused although running")

    client.unsubscribe_topic = refuse
    with pytest.raises(ClosedClientError):
        dask.shutdown(wait=True)
