"""The web viewer's exposure: a warning off loopback, and Host/Origin checked against the served
address (pure functions: no trame needed)."""

from __future__ import annotations

import pytest

from lumijax.errors import LumijaxWarning
from lumijax.view import _web
from lumijax.view._web import allowed_hosts, request_allowed

LOCAL = allowed_hosts("127.0.0.1", 8123)


@pytest.mark.parametrize("host, origin, ok", [
    ("127.0.0.1:8123", None, True),
    ("localhost:8123", "http://localhost:8123", True),
    ("[::1]:8123", "http://[::1]:8123", True),
    ("LOCALHOST:8123", "http://127.0.0.1:8123", True),
    ("127.0.0.1:8124", None, False),                # another port
    ("127.0.0.1", None, False),                     # port 80 implied: not the served one
    ("evil.example:8123", None, False),             # DNS rebinding: the attacker's name
    ("127.0.0.1:8123", "http://evil.example", False),  # a page on another site
    ("127.0.0.1:8123", "null", False),              # sandboxed iframe, file://
    ("127.0.0.1:8123", "http://127.0.0.1:8124", False),
    ("127.0.0.1:8123", "ftp://127.0.0.1:8123", False),
    ("", None, False),
    (None, None, False),
    ("127.0.0.1:80x", None, False),
    ("[::1:8123", None, False),
])
def test_host_and_origin_must_name_the_served_address(host, origin, ok):
    assert request_allowed(host, origin, LOCAL) is ok


def test_a_named_address_allows_only_itself():
    lan = allowed_hosts("192.168.1.20", 9000)
    assert lan == {"192.168.1.20:9000"}
    assert request_allowed("192.168.1.20:9000", "http://192.168.1.20:9000", lan)
    assert not request_allowed("localhost:9000", None, lan)


def test_every_interface_allows_this_machine_but_not_other_names():
    every = allowed_hosts("0.0.0.0", 9000)
    assert {"127.0.0.1:9000", "localhost:9000"} <= every and "0.0.0.0:9000" not in every
    assert not request_allowed("evil.example:9000", None, every)
    # an address of this machine (one it can bind) is allowed by its literal, one it cannot
    # bind (TEST-NET-3, RFC 5737: never assigned) is not
    assert request_allowed("127.0.0.2:9000", "http://127.0.0.2:9000", every)
    assert not request_allowed("203.0.113.7:9000", None, every)
    assert not request_allowed("127.0.0.2:9001", None, every)
    assert not request_allowed("127.0.0.2:9000", None, LOCAL)  # only for a wildcard


class _Served(Exception):
    pass


@pytest.mark.parametrize("host, warns", [("0.0.0.0", True), ("::", True), ("192.168.1.20", True),
                                         ("127.0.0.1", False), ("localhost", False),
                                         ("::1", False)])
def test_serving_beyond_loopback_warns(monkeypatch, host, warns):
    def stop(viewer):
        raise _Served

    monkeypatch.setattr(_web, "web_app", stop)
    with pytest.warns(LumijaxWarning, match="without authentication") if warns else (
            _no_warning()):
        with pytest.raises(_Served):
            _web.serve(None, host=host, port=8000)


class _no_warning:
    def __enter__(self):
        import warnings

        self._cm = warnings.catch_warnings()
        self._cm.__enter__()
        warnings.simplefilter("error", LumijaxWarning)

    def __exit__(self, *exc):
        self._cm.__exit__(*exc)
