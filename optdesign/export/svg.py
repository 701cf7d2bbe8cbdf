"""A DXF document rendered as SVG, to scale, by ezdxf's drawing add-on (one drawing, two
formats: the SVG shows exactly what the DXF holds)."""
from __future__ import annotations

#: white margin around the drawing, mm
MARGIN_MM = 10.0


def svg_text(doc) -> str:
    """The SVG of ``doc``'s model space on a white page fitted to the drawing."""
    from ezdxf.addons.drawing import Frontend, RenderContext, config, layout, svg

    backend = svg.SVGBackend()
    settings = config.Configuration(background_policy=config.BackgroundPolicy.WHITE,
                                    color_policy=config.ColorPolicy.COLOR)
    Frontend(RenderContext(doc), backend, config=settings).draw_layout(doc.modelspace())
    page = layout.Page(0, 0, layout.Units.mm, margins=layout.Margins.all(MARGIN_MM))
    return backend.get_string(page)
