"""BatchJob: the job description every executor passes around and Blender's worker reads. It must
survive pickling and its JSON job file unchanged, and a job file that does not fit the schema is
refused with a message naming the field."""
import dataclasses
import json
import math
import pickle

import pytest

from deformkit.batch.job import FORMAT, BatchJob, JobError

RECIPE = {"objects": ["*"], "deformers": [{"type": "TWIST", "angle": 1.2, "deform_axis": "Z", "limits": [0.1, 0.9]}]}


def a_job(**changes):
    job = BatchJob(index=3, input="/in/a b.blend", output="/out/a b.blend", work="/tmp/run", blender="/usr/bin/blender",
                   token="123-0badc0de", sys_paths=("/tmp/run/addons", "/tmp/run/lib"), recipe=RECIPE,
                   preview=True, smoothness=True, timeout=12.5, never_write=("/in/a b.blend", "/in/c.blend"),
                   parent_pid=4242)
    return dataclasses.replace(job, **changes)


@pytest.mark.parametrize("job", [a_job(), a_job(recipe=None, preview=False, parent_pid=None, sys_paths=())])
def test_json_round_trip(job):
    text = job.to_json()
    assert json.loads(text)["format"] == FORMAT
    back = BatchJob.from_json(text)
    assert back == job and type(back.sys_paths) is tuple and type(back.never_write) is tuple
    assert back.to_json() == text


def test_pickle_round_trip():
    job = a_job()
    back = pickle.loads(pickle.dumps(job))
    assert back == job and back.recipe == RECIPE and back.recipe is not job.recipe


def test_frozen_and_lists_become_tuples():
    job = a_job(sys_paths=["/x"], never_write=["/y"])
    assert job.sys_paths == ("/x",) and job.never_write == ("/y",)
    with pytest.raises(dataclasses.FrozenInstanceError):
        job.input = "/elsewhere.blend"


def test_paths_of_the_job_live_in_its_work_folder_under_its_index():
    job = a_job()
    assert (job.job_path, job.result_path, job.preview_path) == ("/tmp/run/3.job.json", "/tmp/run/3.json",
                                                                 "/tmp/run/3.npz")
    assert a_job(preview=False).preview_path is None


@pytest.mark.parametrize("field, value, expected", [
    ("index", -1, "expected a whole number >= 0"),
    ("index", True, "expected a whole number >= 0"),
    ("input", "", "expected a non-empty string"),
    ("output", 5, "expected a non-empty string"),
    ("work", "a\x00b", "expected a non-empty string"),
    ("token", None, "expected a non-empty string"),
    ("sys_paths", "/one/path", "expected a list of strings"),
    ("recipe", ["TWIST"], "expected a recipe table or null"),
    ("preview", "yes", "expected true or false"),
    ("smoothness", 1, "expected true or false"),
    ("timeout", 0, "expected a finite number of seconds above 0"),
    ("timeout", math.inf, "expected a finite number of seconds above 0"),
    ("timeout", "600", "expected a finite number of seconds above 0"),
    ("parent_pid", 0, "expected a whole number >= 1 or null"),
])
def test_schema_errors_name_the_field(field, value, expected):
    with pytest.raises(JobError, match=f"^job field '{field}': {expected}"):
        a_job(**{field: value})
    data = a_job().to_dict()
    data[field] = value
    with pytest.raises(JobError, match=f"^job field '{field}': {expected}"):
        BatchJob.from_dict(data)


def test_an_item_of_a_list_is_named():
    with pytest.raises(JobError, match=r"^job field 'never_write\[1\]': expected a non-empty string"):
        a_job(never_write=("/a.blend", 7))


def test_job_files_of_another_layout_are_refused():
    data = a_job().to_dict()
    with pytest.raises(JobError, match="^job field 'format': expected 'deformkit-batch-job/1', got None"):
        BatchJob.from_dict({k: v for k, v in data.items() if k != "format"})
    with pytest.raises(JobError, match="^job field 'result': not a field of a job"):
        BatchJob.from_dict({**data, "result": "/tmp/run/3.json"})  # the old job files' key
    with pytest.raises(JobError, match="^job field 'blender': missing"):
        BatchJob.from_dict({k: v for k, v in data.items() if k != "blender"})
    with pytest.raises(JobError, match="^job: not valid JSON"):
        BatchJob.from_json("{")
    with pytest.raises(JobError, match="^job: expected a table, got list"):
        BatchJob.from_json("[]")
