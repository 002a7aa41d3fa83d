"""Device URLs: one parser names what is wrong with a tracker's or a robot's URL in one line."""

import pytest
from cli_kit import cli, listing, one_line_error

from drivers import urls


@pytest.mark.parametrize(
    ("url", "says"),
    [
        ("socket://", "'socket://': missing host (use socket://HOST:PORT)"),
        ("socket://127.0.0.1:99999", "'socket://127.0.0.1:99999': port 99999 is out of 1..65535"),
        ("socket://127.0.0.1:0", "port 0 is out of 1..65535"),
        ("socket://127.0.0.1", "missing port (use socket://HOST:PORT)"),
        ("socket://127.0.0.1:abc", "port 'abc' is not a number"),
        ("socket://:5000", "missing host"),
        ("socket://h:5000?foo=1", "unknown parameter 'foo' (socket:// takes logging)"),
        ("socket://h:5000?logging=loud", "logging='loud' is not one of debug, info"),
        ("rfc2217://", "'rfc2217://': missing host (use rfc2217://HOST:PORT)"),
        ("emscon://h:99999", "'emscon://h:99999': port 99999 is out of 1..65535"),
        ("emscon://h?x=1", "unknown parameter 'x' (emscon:// takes meteo)"),
        ("emscon://h?meteo=1e308,1000,40", "meteo T degC 1e+308 is outside [-40, 60]"),
        ("loop://?x=1", "'loop://?x=1': unknown parameter 'x' (loop:// takes logging)"),
        ("loop://h", "'loop://h': loop:// takes no host (use loop://)"),
    ],
)
def test_a_bad_tracker_url_is_one_line_naming_what_is_wrong(tmp_path, url, says):
    before = listing(tmp_path)
    line = one_line_error(cli("tracker", "status", "--tracker", url, cwd=tmp_path))
    assert line == f"calibrator: error: --tracker: {says}" or says in line, line
    assert "NoneType" not in line and "debug|info" not in line
    assert listing(tmp_path) == before


@pytest.mark.parametrize(
    ("url", "says"),
    [
        ("ur://", "--robot: 'ur://': missing host (use ur://HOST)"),
        ("ur://h:80", "--robot: 'ur://h:80': ur:// takes no port (use ur://HOST)"),
        ("ur://h?x=1", "--robot: 'ur://h?x=1': ur:// takes no parameters"),
        ("ur://h/x", "--robot: 'ur://h/x': unexpected path '/x'"),
        ("ur://a b", "--robot: 'ur://a b': not a URL (use ur://HOST)"),
    ],
)
def test_a_bad_robot_url_is_one_line_naming_what_is_wrong(tmp_path, url, says):
    line = one_line_error(
        cli("measure", "--robot", url, "--tracker", "sim", "--poses", "3", cwd=tmp_path)
    )
    assert line == f"calibrator: error: {says}"
    assert list(tmp_path.iterdir()) == []


def test_good_urls_keep_their_parts():
    got = urls.parse("socket://Tracker.local:5000?logging=info", "socket", port="required",
                     params={"logging": urls.LOGGING})  # fmt: skip
    assert (got.host, got.port, got.params) == ("Tracker.local", 5000, {"logging": "info"})
    assert urls.parse("emscon://[::1]", "emscon", default_port=700).port == 700
    assert urls.parse("ur://10.0.0.5/", "ur", port="none").host == "10.0.0.5"
