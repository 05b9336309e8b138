"""The dimmer viewer in a browser: trame serves the viewer's render window on localhost.

The picture is rendered on the server (VTK remote view) and streamed to the page; a slider per
network and a realistic/false-colour switch are bound to :class:`DimmerViewer`.

The viewer has no authentication: anyone who reaches the port sees the study and moves its
dimmers. It therefore serves on the loopback address by default, warns when told to serve on
another, and answers only requests whose ``Host`` (and ``Origin``, when the browser sends one)
names the served address (:func:`request_allowed`): a page on another site cannot drive it from
the user's browser, even through DNS rebinding.
"""

from __future__ import annotations

import ipaddress
import socket
import warnings
from urllib.parse import urlsplit

from ..errors import LumijaxError, LumijaxWarning

__all__ = ["serve", "web_app", "TrameMissing", "allowed_hosts", "request_allowed"]

_WILDCARDS = ("0.0.0.0", "::", "")


def _is_loopback(host: str) -> bool:
    if host == "localhost":
        return True
    try:
        return ipaddress.ip_address(host.strip("[]")).is_loopback
    except ValueError:
        return False


def _netloc(name: str, port: int) -> str:
    name = name.strip("[]").lower()
    return f"[{name}]:{port}" if ":" in name else f"{name}:{port}"


def allowed_hosts(host: str, port: int) -> frozenset[str]:
    """The ``host:port`` values a request's ``Host`` may carry for a viewer served on
    ``host:port``: the address itself, the loopback names when it is a loopback (or wildcard)
    address, and this machine's name and addresses when it is a wildcard (0.0.0.0, ::)."""
    names = {host}
    if _is_loopback(host) or host in _WILDCARDS:
        names |= {"localhost", "127.0.0.1", "::1"}
    if host in _WILDCARDS:
        names.discard(host)
        names |= {socket.gethostname(), _LOCAL_IP}
        try:
            name, aliases, addrs = socket.gethostbyname_ex(socket.gethostname())
            names |= {name, *aliases, *addrs, socket.getfqdn()}
        except OSError:  # no resolvable host name: the names above only
            pass
    return frozenset(_netloc(n, port) for n in names if n)


_LOCAL_IP = "local-ip"  # in allowed_hosts: any IP literal that is an address of this machine


def _is_local_ip(name: str) -> bool:
    """Whether ``name`` is an IP literal of one of this machine's interfaces (it can be bound).
    Only literals: a DNS name (the rebinding attack's) is never resolved here."""
    try:
        ip = ipaddress.ip_address(name.strip("[]"))
    except ValueError:
        return False
    try:
        with socket.socket(socket.AF_INET6 if ip.version == 6 else socket.AF_INET) as s:
            s.bind((str(ip), 0))
    except OSError:
        return False
    return True


def request_allowed(host_header: str | None, origin_header: str | None,
                    allowed: frozenset[str]) -> bool:
    """Whether a request with these ``Host`` and ``Origin`` headers may reach the viewer.

    ``Host`` must be one of ``allowed`` (see :func:`allowed_hosts`); ``Origin``, when present,
    must be ``http://`` or ``https://`` one of them too (``null`` and other sites are refused).
    """
    if not host_header or not _allowed(_host_port(host_header), allowed):
        return False
    if origin_header is None:
        return True  # not a browser's cross-origin request (curl, the page's own GET)
    parts = urlsplit(origin_header.strip())
    if parts.scheme not in ("http", "https") or not parts.netloc:
        return False
    return _allowed(_host_port(parts.netloc, 443 if parts.scheme == "https" else 80), allowed)


def _allowed(netloc: str, allowed: frozenset[str]) -> bool:
    if netloc in allowed:
        return True
    name, _, port = netloc.rpartition(":")
    return bool(name) and f"{_LOCAL_IP}:{port}" in allowed and _is_local_ip(name)


def _host_port(netloc: str, default: int = 80) -> str:
    """``Host``/``Origin`` authority → ``name:port`` as :func:`allowed_hosts` spells it ("" if
    malformed)."""
    netloc = netloc.strip().lower()
    if netloc.startswith("["):  # [v6]:port or [v6]
        end = netloc.find("]")
        if end < 0:
            return ""
        name, rest = netloc[1:end], netloc[end + 1 :]
        port = rest[1:] if rest.startswith(":") else ""
    elif netloc.count(":") == 1:
        name, port = netloc.split(":")
    else:
        name, port = netloc, ""
    if port and not port.isdigit():
        return ""
    return _netloc(name, int(port) if port else default)


class TrameMissing(LumijaxError):
    """The optional ``view`` extra (trame) is not installed."""


def _require_trame() -> None:
    try:
        import trame  # noqa: F401
        import trame_vtk  # noqa: F401
        import trame_vuetify  # noqa: F401
    except ImportError:
        raise TrameMissing(
            "the web viewer needs trame: pip install 'lumijax[view]' "
            "(trame, trame-vtk, trame-vuetify)") from None


def web_app(viewer, *, name: str = "lumijax"):
    """A trame server (not started) showing ``viewer`` with its sliders."""
    _require_trame()
    from trame.app import get_server
    from trame.ui.vuetify3 import SinglePageLayout
    from trame.widgets import html, vtk as vtk_widgets, vuetify3 as v3

    server = get_server(name, client_type="vue3")
    state, ctrl = server.state, server.controller
    keys = {net: f"dimmer_{i}" for i, net in enumerate(viewer.networks)}
    for net, key in keys.items():
        state[key] = float(viewer.dimmers[viewer.networks.index(net)])
    state.falsecolour = False
    state.trame__title = f"lumijax — {viewer.study.name}"

    def on_change(**changed):
        for net, key in keys.items():
            if key in changed:
                viewer.set_dimmer(net, float(changed[key]))
        if "falsecolour" in changed:
            viewer.set_mode("falsecolour" if changed["falsecolour"] else "realistic")
        ctrl.view_update()

    state.change(*keys.values(), "falsecolour")(on_change)

    with SinglePageLayout(server) as layout:
        layout.title.set_text(f"lumijax — {viewer.study.name}")
        with layout.toolbar:
            v3.VSpacer()
            v3.VSwitch(v_model=("falsecolour", False), label="false colour (cd/m²)",
                       hide_details=True, density="compact", classes="mr-4",
                       id="falsecolour-switch")
        with layout.content:
            with html.Div(style="display: flex; height: calc(100vh - 64px);"):
                with html.Div(style="width: 280px; padding: 16px; flex: none;", id="dimmers"):
                    html.Div("Dimmers", classes="text-subtitle-1 mb-2")
                    for net, key in keys.items():
                        v3.VSlider(v_model=(key,), min=0, max=1, step=0.01, label=net,
                                   thumb_label=True, hide_details=True, density="compact",
                                   classes=f"mb-3 slider-{key}", id=f"slider-{key}")
                with html.Div(style="flex: 1; height: 100%; position: relative;", id="view"):
                    view = vtk_widgets.VtkRemoteView(viewer.plotter.render_window,
                                                     interactive_ratio=1, still_quality=90)
                    ctrl.view_update = view.update
                    ctrl.on_server_ready.add(view.update)
    return server


def serve(viewer, *, host: str = "127.0.0.1", port: int = 0, open_browser: bool = False,
          **kwargs) -> None:
    """Serve the web viewer on ``http://host:port/`` (blocks until stopped); ``port=0`` picks
    a free port. The address is printed as ``lumijax view: http://...`` once known.

    A ``host`` other than a loopback address gives a :class:`LumijaxWarning` (no
    authentication); requests whose ``Host`` or ``Origin`` do not name the served address are
    answered 403 (:func:`request_allowed`).
    """
    if not _is_loopback(host):
        warnings.warn(
            f"serving the viewer on {host or 'every interface'} without authentication: anyone "
            "who can reach this port can see the study and move its dimmers (the default, "
            "--host 127.0.0.1, serves this machine only)", LumijaxWarning, stacklevel=2)
    server = web_app(viewer)
    if not port:
        with socket.socket(socket.AF_INET6 if ":" in host else socket.AF_INET) as s:
            s.bind((host, 0))
            port = s.getsockname()[1]
    allowed = allowed_hosts(host, port)

    def guard(wslink_server):  # trame hands over its aiohttp application before it starts
        from aiohttp import web

        @web.middleware
        async def check(request, handler):
            if not request_allowed(request.headers.get("Host"), request.headers.get("Origin"),
                                   allowed):
                return web.Response(status=403, text="lumijax view: this Host or Origin is not "
                                    "the address the viewer serves\n")
            return await handler(request)

        try:
            wslink_server.app.middlewares.append(check)
        except (AttributeError, RuntimeError, TypeError):  # another backend, or a frozen app
            warnings.warn("cannot install the Host/Origin check on this trame backend: the "
                          "viewer answers any Host and Origin", LumijaxWarning, stacklevel=1)

    server.controller.on_server_bind.add(guard)
    print(f"lumijax view: http://{_netloc(host, port)}/", flush=True)
    server.start(host=host, port=port, open_browser=open_browser, **kwargs)
