"""The manifest's defaultVariant (the file the page and createGenerator run unless asked otherwise) as the export
writes it: set by --default-variant, kept by a re-export while that file is still exported, refused when it names
a file the export does not make."""

import json

from emdm.export import main as export_main
from emdm.train import main as train_main
from model_synth_data import write_synthetic_dataset

TINY = ["--preset", "tiny", "--d-width", "32", "--batch", "4", "--threads", "1", "--no-progress"]


def test_default_variant_written_kept_dropped_and_refused(tmp_path, capsys):
    ds = write_synthetic_dataset(tmp_path / "ds", n_clips=12)
    assert train_main(["--data", str(ds), "--task", "action", "--out", str(tmp_path / "run"), "--steps", "2", *TINY]) in (0, None)
    out = tmp_path / "models"

    def entry():
        return json.loads((out / "manifest.json").read_text())["models"]["m"]

    base = ["--ckpt", str(tmp_path / "run" / "ckpt.pt"), "--name", "m", "--out", str(out)]
    assert export_main(base + ["--variants", "int8", "--default-variant", "int8"]) == 0
    e = entry()
    assert e["defaultVariant"] == "int8" and e["defaultVariant"] in e["variants"]
    assert list(e).index("defaultVariant") == list(e).index("variants") + 1
    assert export_main(base + ["--variants", "int8"]) == 0          # a re-export keeps the choice
    assert entry()["defaultVariant"] == "int8"
    assert export_main(base + ["--variants", "int8", "--default-variant", "fp32"]) == 0
    assert "defaultVariant" not in entry()                              # fp32: the onnx file, no field
    assert export_main(base + ["--variants", "int8", "--default-variant", "int8"]) == 0
    assert export_main(base + ["--variants", ""]) == 0                 # the int8 file is no longer made: dropped
    assert "defaultVariant" not in entry()
    before = (out / "manifest.json").read_text()
    assert export_main(base + ["--variants", "int8", "--default-variant", "fp16"]) == 2
    assert "--default-variant 'fp16' is not among the exported files: use fp32 or one of --variants (int8)" in capsys.readouterr().err
    assert (out / "manifest.json").read_text() == before               # refused before anything was written
