import tomllib
from pathlib import Path

import pytest

from gesturebank import config
from gesturebank.config import Config, load_config, parse_override
from gesturebank.errors import ConfigError

EXAMPLE = Path(__file__).parents[1] / "gesturebank.toml"


def write(tmp_path: Path, text: str) -> Path:
    path = tmp_path / "my.toml"
    path.write_text(text)
    return path


def test_defaults_match_the_dissertation() -> None:
    c = Config()
    assert (c.processing.rate_hz, c.processing.butter_order, c.processing.cutoff_hz) == (100, 5, 4)
    assert (c.audio.sample_rate, c.audio.nfft, c.audio.nfilt, c.audio.preemph) == (
        16000,
        512,
        26,
        0.97,
    )
    assert c.detector.mediapipe.model_complexity == 1


def test_precedence_defaults_file_cli(tmp_path: Path) -> None:
    path = write(tmp_path, "[audio]\nnfilt = 40\n[processing]\ncutoff_hz = 6.0\n")
    from_file = load_config(path)
    assert from_file.audio.nfilt == 40
    assert from_file.processing.cutoff_hz == 6.0
    assert from_file.processing.butter_order == 5  # untouched keys keep their defaults
    both = load_config(path, [parse_override("audio.nfilt=30")])
    assert both.audio.nfilt == 30  # the command line wins over the file
    assert both.processing.cutoff_hz == 6.0  # the file still wins over the default
    later = load_config(path, [{"audio": {"nfilt": 30}}, {"audio": {"nfilt": 20}}])
    assert later.audio.nfilt == 20


def test_bad_key_is_one_line_naming_file_and_key(tmp_path: Path) -> None:
    path = write(tmp_path, "[audio]\nnfilters = 40\n")
    with pytest.raises(ConfigError) as exc:
        load_config(path)
    msg = str(exc.value)
    assert "\n" not in msg
    assert str(path) in msg
    assert "audio.nfilters" in msg
    assert "unknown key" in msg


def test_bad_section_and_bad_value(tmp_path: Path) -> None:
    with pytest.raises(ConfigError, match=r"audoi: unknown key"):
        load_config(write(tmp_path, "[audoi]\nnfilt = 40\n"))
    with pytest.raises(ConfigError, match=r"audio\.nfilt: .*less than or equal to 128.*300"):
        load_config(write(tmp_path, "[audio]\nnfilt = 300\n"))
    with pytest.raises(ConfigError, match=r"processing: .*Nyquist"):
        load_config(write(tmp_path, "[processing]\ncutoff_hz = 60.0\n"))
    with pytest.raises(ConfigError, match="command line: audio.nfilt"):
        load_config(None, [parse_override("audio.nfilt=-3")])


def test_unreadable_files(tmp_path: Path) -> None:
    with pytest.raises(ConfigError, match="not found"):
        load_config(tmp_path / "missing.toml")
    with pytest.raises(ConfigError, match="not valid TOML"):
        load_config(write(tmp_path, "[audio\n"))


def test_parse_override_types() -> None:
    assert parse_override("audio.nfilt=40") == {"audio": {"nfilt": 40}}
    assert parse_override("detector.name=openpose-json") == {"detector": {"name": "openpose-json"}}
    assert parse_override('build.video_extensions=[".mp4"]') == {
        "build": {"video_extensions": [".mp4"]}
    }
    with pytest.raises(ConfigError, match="SECTION.KEY=VALUE"):
        parse_override("nonsense")


def test_example_file_covers_every_key_at_its_default() -> None:
    data = tomllib.loads(EXAMPLE.read_text())
    defaults = Config().to_json_dict()
    assert set(data) == set(defaults)
    for section, keys in defaults.items():
        set_keys = {k for k, v in keys.items() if v is not None}
        assert set(data[section]) == set_keys, section
        # keys left unset (None) are present as comments, so users see them
        for key in set(keys) - set_keys:
            assert f"# {key} = " in EXAMPLE.read_text(), key
    assert load_config(EXAMPLE) == Config()


def test_digest_tracks_changes() -> None:
    a, b = Config(), load_config(None, [{"audio": {"nfilt": 40}}])
    assert a.digest() != b.digest()
    assert a.digest("processing") == b.digest("processing")


@pytest.mark.parametrize(
    ("item", "expected"),
    [
        ("train.lstm.epochs=3", "train.lstm.epochs: unknown key (did you mean max_epochs?)"),
        ("qc.max_facing_away_fracion=0.2", "(did you mean max_facing_away_fraction?)"),
        ("trian.patience=3", "trian: unknown key (did you mean train?)"),
        ("train.lstm.zzz=1", "(valid: units, seq_len, stride, batch_size, max_epochs)"),
    ],
)
def test_set_key_error_suggests_the_nearest_key(item: str, expected: str) -> None:
    with pytest.raises(ConfigError) as exc:
        load_config(None, [parse_override(item)])
    assert str(exc.value).startswith("command line: ") and expected in str(exc.value)


def test_misspelt_key_in_a_file_names_file_line_and_nearest_key(tmp_path: Path) -> None:
    path = write(
        tmp_path,
        "# my settings\n[qc]\nmax_people = 3\n\nmax_facing_away_fracion = 0.2\n"
        "[train]\nlstm.epochs = 3\n",
    )
    with pytest.raises(ConfigError) as exc:
        load_config(path)
    assert str(exc.value) == (
        f"{path}:5: qc.max_facing_away_fracion: unknown key "
        "(did you mean max_facing_away_fraction?); "
        f"{path}:7: train.lstm.epochs: unknown key (did you mean max_epochs?)"
    )


def test_an_unknown_section_in_a_file_points_at_its_header(tmp_path: Path) -> None:
    path = write(tmp_path, "[audio]\nnfilt = 26\n\n[trian.lstm]\nmax_epochs = 3\n")
    with pytest.raises(ConfigError, match=r":4: trian: unknown key \(did you mean train\?\)"):
        load_config(path)


def test_the_commented_example_ships_in_the_package_and_is_the_repository_file() -> None:
    from typer.testing import CliRunner

    from gesturebank.cli import app
    from gesturebank.config import commented_example

    packaged = Path(config.__file__).parents[1] / "data" / "gesturebank.toml"
    assert packaged.samefile(EXAMPLE)  # one file: the package's is a link to the top-level one
    text = commented_example()
    assert text == EXAMPLE.read_text(encoding="utf-8") and text.count("\n# ") > 100
    r = CliRunner().invoke(app, ["config", "--commented"])
    assert r.exit_code == 0 and r.output == text
    assert Config.model_validate(tomllib.loads(r.output)) == Config()  # every key at its default
    refused = CliRunner().invoke(app, ["config", "--commented", "--set", "audio.nfilt=20"])
    assert refused.exit_code == 2
