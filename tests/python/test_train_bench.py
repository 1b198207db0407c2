"""emdm.model.bench_train runs an old and a new training loop on the same synthetic data and reports samples/s."""

import json

from emdm import paths
from emdm.model import bench_train


def test_bench_reports_samples_per_second_for_each_loop(tmp_path, capsys):
    out = tmp_path / "bench.json"
    assert bench_train.main(["--synthetic", "12", "--device", "cpu", "--threads", "1", "--task", "action",
                             "--preset", "tiny", "--batch", "4", "--steps", "4", "--log-every", "2",
                             "--extra", "--d-width 32", "--old-src", str(paths.REPO_ROOT / "scripts"),
                             "--new", "--balance-alpha 0", "--json", str(out)]) == 0
    lines = capsys.readouterr().out.strip().splitlines()
    assert lines[0].startswith("new --balance-alpha 0") and lines[1].startswith("old (") and "samples/s" in lines[0]
    assert lines[2].startswith("samples/s relative to the old loop: new --balance-alpha 0 ×")
    res = json.loads(out.read_text())["results"]
    assert res[1]["vs_old"] == 1.0
    assert [r["batch"] for r in res] == [4, 4] and all(r["samples_per_s"] > 0 and r["steps_timed"] == 1 for r in res)
    assert abs(res[0]["samples_per_s"] - 4 / res[0]["sec_per_step"]) < 1e-9
    assert abs(res[0]["vs_old"] - res[0]["samples_per_s"] / res[1]["samples_per_s"]) < 1e-9
