"""fit's sites= (fit --sites) and checkpoint= (fit --checkpoint) give the command's posterior file."""

import filecmp
import json

import pytest

import ssrfleet


def test_a_manifests_sites_fit_as_the_command_fits_them(cli, tmp_path):
    cli("simulate", "--trucks", 5, "--seed", 1, "--out", tmp_path / "north.csv", "-q")
    cli("simulate", "--trucks", 4, "--seed", 2, "--road", "AS2", "--sensors", "40,2,8", "--out",
        tmp_path / "south.csv", "-q")
    manifest = tmp_path / "sites.json"
    manifest.write_text(json.dumps({"sites": [
        {"name": "north", "road": "AS1", "sensors": "76,1.5,16", "log": "north.csv"},
        {"name": "south", "road": "AS2", "sensors": "40,2,8", "log": "south.csv"}]}))
    expected = tmp_path / "expected.json"
    cli("fit", "--sites", manifest, "--particles", 16, "--final-sweeps", 0, "--seed", 3, "--out", expected, "-q")
    posterior = ssrfleet.fit(sites=str(manifest), particles=16, final_sweeps=0, seed=3)
    mine = tmp_path / "mine.json"
    posterior.to_json(mine)
    assert filecmp.cmp(mine, expected, shallow=False)
    assert posterior.info()["trucks_seen"] == 9
    with pytest.raises(ssrfleet.UsageError, match="not both"):
        ssrfleet.fit(str(tmp_path / "north.csv"), sites=str(manifest))


def test_a_checkpointed_fit_resumes_to_the_commands_bits(small_log, cli, tmp_path):
    path, arrays = small_log
    expected = tmp_path / "expected.json"
    cli("fit", path, "--particles", 16, "--final-sweeps", 0, "--seed", 4, "--out", expected, "-q")
    folder = tmp_path / "ckpt"
    first = ssrfleet.fit(arrays, particles=16, final_sweeps=0, seed=4, checkpoint=folder, checkpoint_every_trucks=3)
    assert any(folder.iterdir())  # checkpoints were written
    again = ssrfleet.fit(arrays, particles=16, final_sweeps=0, seed=4, checkpoint=folder)  # resumes from the last
    for posterior in (first, again):
        mine = tmp_path / "mine.json"
        posterior.to_json(mine)
        assert filecmp.cmp(mine, expected, shallow=False)
    with pytest.raises(ssrfleet.UsageError, match="checkpoint"):
        ssrfleet.fit(arrays, method="mcmc", checkpoint=folder)
