"""The explorer's sliders: Panel's editable float slider and discrete slider, answered as
soon as they move; and its text panes, whose new text is all a redraw sends of them.

Panel waits 50 ms after a slider's value arrives from the browser before it runs the
widget's callbacks (its ``_debounce``: changes arriving meanwhile are merged into one). On
the explorer's page that wait was a third of a move's round trip, and it merges nothing the
server would not merge anyway: while a move is being evaluated, the values that arrive are
merged into one change, and the next evaluation takes the newest. :class:`PromptSlider` (a
length, a bound, the drawn eccentricity) and :class:`PromptDiscreteSlider` (the count) run
their callbacks on the next turn of the server's loop instead.

One thing it waits for: the server's acknowledgement of the move (a message of three
frames, each frame one turn of the loop) still being written to the page. Panel sends a
callback's changes at once only when no message is half-written to the page's socket, else
it tries again every 10 ms; so the callbacks start once the socket is free, and the page's
update leaves the server as soon as they end, in one message (the slider's number field
with the redraw).

And one thing the server's sockets must not do: hold a small frame back until the page has
acknowledged the previous one (Nagle's algorithm, which Tornado's websockets keep on). A reply
is several frames written one after another (three for a message, two more for each array);
the page acknowledges a segment only after its delayed-acknowledgement timer (40 ms on Linux),
so a move's reply could wait that long before its last frames left the server.
:func:`send_at_once` turns that off for every page showing a document; and while the move's
reply is written, :func:`corked` holds its frames so that they leave together, the page
taking them in at once rather than one packet at a time.

Importing this module imports Panel.
"""
from __future__ import annotations

from contextlib import contextmanager

from panel.pane import HTML
from panel.widgets import DiscreteSlider, EditableFloatSlider, FloatSlider, IntSlider


class _Prompt:
    """What makes a Panel slider prompt: a value from the browser is processed on the next
    turn of the loop (no 50 ms wait), once no message is half-written to the page, and the
    move's changes leave in one message."""

    _debounce = 0
    #: the page shows no busy indicator: Panel's count of busy events (a millisecond a
    #: move) is kept for none
    _busy__ignore = ["value", "value_throttled"]

    async def _change_coroutine(self, doc, event_id=None) -> None:
        from panel.io import hold
        from panel.io.state import set_curdoc

        send_at_once(doc)
        await sockets_free(doc)
        # every change of the move in one message, its frames sent together
        with corked(doc), set_curdoc(doc), hold(doc):
            await super()._change_coroutine(doc, event_id)


class _PromptFloatSlider(_Prompt, FloatSlider):
    """The slider part of :class:`PromptSlider`."""


class _PromptIntSlider(_Prompt, IntSlider):
    """The slider part of :class:`PromptDiscreteSlider`."""


class PromptSlider(EditableFloatSlider):
    """An :class:`~panel.widgets.EditableFloatSlider` whose moves are answered at once."""

    _slider_widget = _PromptFloatSlider


class PromptDiscreteSlider(DiscreteSlider):
    """A :class:`~panel.widgets.DiscreteSlider` (the count's) whose moves are answered at
    once."""

    def _update_options(self, *events) -> None:
        super()._update_options(*events)
        # the slider over the options' indices Panel has just built: the same object,
        # answered as PromptSlider's is (it adds no state of its own)
        self._slider.__class__ = _PromptIntSlider


#: the longest wait for a page's socket [s]: a page that stops reading holds a message
#: half-written, and the move is then answered anyway (Panel sends it when it can)
LONGEST_WAIT = 0.25


def _sockets(doc) -> list:
    """The websockets of the pages showing ``doc`` (none outside a server)."""
    context = getattr(doc, "session_context", None)
    session = getattr(context, "session", None)
    return [getattr(connection, "_socket", None)
            for connection in list(getattr(session, "_subscribed_connections", ()))]


def send_at_once(doc) -> None:
    """Every frame written to a page showing ``doc`` leaves at once (TCP_NODELAY on its
    socket, once per socket); nothing outside a server."""
    for socket in _sockets(doc):
        if socket is None or getattr(socket, "_sends_at_once", False) \
                or not hasattr(socket, "set_nodelay") \
                or getattr(socket, "ws_connection", None) is None:
            continue
        socket.set_nodelay(True)
        socket._sends_at_once = True


@contextmanager
def corked(doc):
    """Within it, the frames written to the pages showing ``doc`` are held by the system and
    leave together when it ends (TCP_CORK, where the system has it): a move's reply is two
    frames for each of its arrays, each of which would otherwise be a packet of its own for
    the page to take in one at a time. Nothing outside a server."""
    import socket as sockets

    held = []
    if hasattr(sockets, "TCP_CORK"):
        for page in _sockets(doc):
            raw = getattr(getattr(getattr(page, "ws_connection", None), "stream", None),
                          "socket", None)
            if raw is None:
                continue
            try:
                raw.setsockopt(sockets.IPPROTO_TCP, sockets.TCP_CORK, 1)
            except OSError:
                continue
            held.append(raw)
    try:
        yield
    finally:
        for raw in held:
            try:
                raw.setsockopt(sockets.IPPROTO_TCP, sockets.TCP_CORK, 0)
            except OSError:             # the page has gone: nothing to send
                pass


async def sockets_free(doc) -> None:
    """Return once no message is being written to a page showing ``doc`` (each page's
    socket holds its write lock while a message's frames go out), or after
    :data:`LONGEST_WAIT`; at once outside a server."""
    from datetime import timedelta

    from tornado.util import TimeoutError as Timeout

    for socket in _sockets(doc):
        lock = getattr(socket, "write_lock", None)
        if lock is None:
            continue
        try:
            with await lock.acquire(timeout=timedelta(seconds=LONGEST_WAIT)):
                pass
        except Timeout:
            return


class TextPane(HTML):
    """Panel's HTML pane whose new text is all that is sent to its model when it changes
    (Panel sets every property of the model again: about a millisecond a pane, two panes a
    move)."""

    def _update(self, ref, model) -> None:
        model.text = self._transform_object(self.object)["object"]
