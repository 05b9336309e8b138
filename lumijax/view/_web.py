"""The dimmer viewer in a browser: trame serves the viewer's render window on localhost.

The picture is rendered on the server (VTK remote view) and streamed to the page; a slider per
network and a realistic/false-colour switch are bound to :class:`DimmerViewer`.
"""

from __future__ import annotations

from ..errors import LumijaxError

__all__ = ["serve", "web_app", "TrameMissing"]


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
    a free port. The address is printed as ``lumijax view: http://...`` once known."""
    server = web_app(viewer)
    if not port:
        import socket

        with socket.socket() as s:
            s.bind((host, 0))
            port = s.getsockname()[1]
    print(f"lumijax view: http://{host}:{port}/", flush=True)
    server.start(host=host, port=port, open_browser=open_browser, **kwargs)
