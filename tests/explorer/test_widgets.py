"""The explorer's slider: answered without Panel's wait, once the page's socket is free (the
browser test drives it through a real server; these check the parts alone)."""
import asyncio
from types import SimpleNamespace

import pytest

pytest.importorskip("panel")

from optdesign.explorer import widgets  # noqa: E402
from optdesign.explorer.widgets import (PromptDiscreteSlider, PromptSlider,  # noqa: E402
                                        TextPane, corked, send_at_once, sockets_free)


def _page_showing(lock) -> SimpleNamespace:
    """A document whose one page's socket has ``lock`` as its write lock, as Bokeh's
    server session holds its connections."""
    connection = SimpleNamespace(_socket=SimpleNamespace(write_lock=lock))
    session = SimpleNamespace(_subscribed_connections=[connection])
    return SimpleNamespace(session_context=SimpleNamespace(session=session))


def test_the_slider_is_panels_editable_slider_without_its_wait():
    w = PromptSlider(start=20, end=150, value=56.0, step=0.2)
    assert w._slider_widget._debounce == 0
    w._slider.value = 56.2                   # a move of the handle reaches the widget's value
    assert w.value == 56.2 and w._value_edit.value == 56.2


def test_the_count_slider_is_panels_discrete_slider_without_its_wait():
    w = PromptDiscreteSlider(options=[4, 5, 6, 8], value=5)
    assert w._slider._debounce == 0
    w._slider.value = 3                      # the handle on the fourth option
    assert w.value == 8
    w.options = [4, 6]                       # Panel builds the slider anew: prompt still
    assert w._slider._debounce == 0 and w.value == 4


def test_a_move_is_not_counted_busy():
    """The page shows no busy indicator: a move leaves Panel's busy count alone."""
    from panel.io.state import state

    w = PromptSlider(start=20, end=150, value=56.0, step=0.2)
    seen = []
    watcher = state.param.watch(lambda e: seen.append(e.new), "busy")
    try:
        w._slider._process_events({"value": 56.2})
    finally:
        state.param.unwatch(watcher)
    assert w.value == 56.2 and seen == []


def test_a_text_pane_sends_its_new_text_alone():
    """What a redraw sends of a text pane: its text, as Panel's HTML pane renders it."""
    import panel as pn
    from bokeh.document import Document

    text = "<b class='explore-delta'>δ = 0.376413</b> &amp; more"
    pane, html = TextPane("", width=560), pn.pane.HTML(text, width=560)
    doc = Document()
    model = pane.get_root(doc)
    doc.add_root(model)
    events = []
    doc.callbacks.on_change(events.append)
    pane.object = text
    pane._update(model.ref["id"], model)     # what a served page's redraw runs
    assert [e.attr for e in events] == ["text"]
    assert model.text == html.get_root(Document()).text


def test_no_server_no_wait():
    from bokeh.document import Document

    asyncio.run(sockets_free(Document()))
    asyncio.run(sockets_free(SimpleNamespace()))


def test_a_half_written_message_is_waited_for():
    from tornado.locks import Lock

    async def main():
        lock = Lock()
        await lock.acquire()                 # a message's frames going out
        waiting = asyncio.ensure_future(sockets_free(_page_showing(lock)))
        for _ in range(5):
            await asyncio.sleep(0)
        assert not waiting.done()
        lock.release()                       # the last frame written
        await waiting

    asyncio.run(main())


def test_a_page_that_stops_reading_holds_nothing_back(monkeypatch):
    from tornado.locks import Lock

    monkeypatch.setattr(widgets, "LONGEST_WAIT", 0.01)

    async def main():
        lock = Lock()
        await lock.acquire()                 # never released
        await sockets_free(_page_showing(lock))

    asyncio.run(main())


def test_every_frame_leaves_at_once():
    """The page's socket sends each frame as it is written (TCP_NODELAY), set once."""
    calls = []
    socket = SimpleNamespace(ws_connection=object(), set_nodelay=calls.append)
    session = SimpleNamespace(_subscribed_connections=[SimpleNamespace(_socket=socket)])
    doc = SimpleNamespace(session_context=SimpleNamespace(session=session))
    send_at_once(doc)
    send_at_once(doc)
    assert calls == [True]
    send_at_once(SimpleNamespace())                 # outside a server: nothing to do


def test_a_reply_leaves_together():
    """While a move's reply is written its frames are held (TCP_CORK), and let go after,
    whatever happened meanwhile."""
    import socket

    if not hasattr(socket, "TCP_CORK"):
        pytest.skip("no TCP_CORK on this system")
    with socket.socket() as listening:
        listening.bind(("127.0.0.1", 0))
        listening.listen()
        with socket.create_connection(listening.getsockname()) as raw:
            page = SimpleNamespace(ws_connection=SimpleNamespace(
                stream=SimpleNamespace(socket=raw)))
            session = SimpleNamespace(_subscribed_connections=[SimpleNamespace(_socket=page)])
            doc = SimpleNamespace(session_context=SimpleNamespace(session=session))
            cork = (socket.IPPROTO_TCP, socket.TCP_CORK)
            with pytest.raises(RuntimeError):
                with corked(doc):
                    assert raw.getsockopt(*cork) == 1
                    raise RuntimeError("a fault while the reply is written")
            assert raw.getsockopt(*cork) == 0
    with corked(SimpleNamespace()):                 # outside a server: nothing held
        pass
