"""Every command line against every bad form of its arguments (tests/reliability_cases.py): a
non-zero exit, one ``Error:`` line naming the path and the problem, no traceback, nothing
written into the output folder and nothing already there lost; and docs/reliability.md generated from the same table."""

import pytest
from click.testing import CliRunner

from render.cli.check_renderer import main as check_renderer
from render.cli.make_materials import main as make_materials
from render.cli.render_dataset import main as render_dataset
from tests.reliability_cases import CASES, DOC, make_bad_inputs, markdown
from train.cli.sa_estimate import main as sa_estimate
from train.cli.sa_evaluate import main as sa_evaluate
from train.cli.sa_train import main as sa_train
from train.cli.sa_validate import main as sa_validate

COMMANDS = {"render-dataset": render_dataset, "make-materials": make_materials,
            "check-renderer": check_renderer, "sa-train": sa_train, "sa-estimate": sa_estimate,
            "sa-validate": sa_validate, "sa-evaluate": sa_evaluate}
KEPT = "written by an earlier run\n"


@pytest.fixture(scope="module")
def bad_inputs(tmp_path_factory):
    return make_bad_inputs(tmp_path_factory.mktemp("bad-inputs"))


@pytest.mark.parametrize("command, argument, form, argv, named, expected", CASES,
                         ids=[f"{c[0]} {c[1]} {c[2]}" for c in CASES])
def test_bad_input_gets_one_clear_line(bad_inputs, tmp_path, command, argument, form, argv,
                                       named, expected):
    out = tmp_path / "out"
    out.mkdir()
    (out / "kept.txt").write_text(KEPT)
    text_file = bad_inputs.text_file.read_text()
    result = CliRunner().invoke(COMMANDS[command], argv(bad_inputs, out))
    assert result.exit_code != 0, result.output
    assert result.exception is None or isinstance(result.exception, SystemExit), \
        f"uncaught {result.exception!r}"
    assert "Traceback" not in result.output
    errors = [line for line in result.output.splitlines() if line.startswith("Error:")]
    assert len(errors) == 1, result.output
    assert expected in errors[0]
    if named is not None:
        assert str(getattr(bad_inputs, named)) in errors[0]
    assert (out / "kept.txt").read_text() == KEPT
    assert [p.name for p in out.iterdir()] == ["kept.txt"]  # a refused run writes nothing
    assert bad_inputs.text_file.read_text() == text_file
    assert not (bad_inputs.root / "PAYLOAD_RAN").exists()


def test_reliability_doc_is_generated_from_the_cases():
    assert DOC.read_text() == markdown(), "run: .venv/bin/python -m tests.reliability_cases"
