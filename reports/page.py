"""The page kit of every HTML page tribench writes (report, compare, seed): the shell, the CSS once, and the parts.

A page references nothing outside itself (pictures are ``data:`` URIs, the charts' scripts inline), so it opens offline.
Every helper escapes the text it is given; a ``body`` argument is HTML these helpers already made."""

from __future__ import annotations

import base64
import datetime as _dt
import io
import math
from collections.abc import Callable, Iterable, Mapping, Sequence
from html import escape
from typing import Any

import numpy as np
import pandas as pd

from .charts import USED, library

__all__ = [
    "CSS",
    "num",
    "span",
    "plain",
    "p",
    "warn",
    "code",
    "table",
    "kv_table",
    "figure",
    "png_data_uri",
    "palette_png",
    "section",
    "document",
    "now",
]

CSS = """
body{font-family:system-ui,-apple-system,"Segoe UI",Roboto,Helvetica,Arial,sans-serif;margin:0;
 color:#1f2328;background:#fff;line-height:1.45}
main{max-width:1180px;margin:0 auto;padding:12px 28px 60px}
h1{font-size:1.6em;margin:.4em 0 .1em}h2{font-size:1.3em;border-bottom:2px solid #d0d7de;
 padding-bottom:.2em;margin-top:2.2em}h3{font-size:1.05em;margin:1.3em 0 .4em}
nav{position:sticky;top:0;background:#f6f8fa;border-bottom:1px solid #d0d7de;padding:6px 28px;
 font-size:.9em;z-index:2}nav a{margin-right:.9em;color:#0b57d0;text-decoration:none}
.sub{color:#57606a;margin:0 0 1em}
.verdicts{font-size:1.08em;padding-left:1.2em}.verdicts li{margin:.25em 0}
.faster{color:#1a7f37;font-weight:600}.slower{color:#c62828;font-weight:600}
.equivalent{color:#5f6b7a;font-weight:600}.inconclusive{color:#b45309;font-weight:600}.mixed{font-weight:600}
.broken{color:#c62828;font-weight:700;background:#ffebe9}
.warn{background:#fff8c5;border:1px solid #d4a72c;border-radius:6px;padding:6px 12px;margin:.6em 0}
.note{color:#57606a;font-size:.92em}
table{border-collapse:collapse;font-size:.86em;margin:.5em 0 1em}
th,td{border-bottom:1px solid #e5e7eb;padding:3px 9px;text-align:left;vertical-align:top}
th{background:#f6f8fa;font-weight:600}td.num{text-align:right;font-variant-numeric:tabular-nums}
figure{margin:.8em 0 1.4em}figure img{max-width:100%;height:auto;display:block}
figcaption{color:#57606a;font-size:.9em;margin-top:.3em}
pre{background:#f6f8fa;border:1px solid #d0d7de;border-radius:6px;padding:10px;overflow-x:auto;font-size:.85em}
code{font-family:ui-monospace,SFMono-Regular,Menlo,Consolas,monospace;font-size:.92em}
.pictures{display:grid;grid-template-columns:repeat(auto-fill,minmax(520px,1fr));gap:18px}
.pictures.three{grid-template-columns:repeat(3,1fr)}
img.pixels{width:100%;image-rendering:pixelated}
details summary{cursor:pointer;color:#0b57d0}
section>details>summary{list-style-position:outside;margin-top:1.2em}
section>details>summary h2{display:inline-block;margin:0;border:0;color:#1f2328}
section>details[open]>summary h2{border-bottom:2px solid #d0d7de}
figure.chart{overflow-x:auto}
.answer td{font-size:1.02em}.answer th{font-size:.95em}
"""

#: Opens the collapsed section a link or the address points at, or the ``<details>`` around its target.
_OPEN_TARGET = (
    "function tbOpen(){var t=location.hash&&document.getElementById(decodeURIComponent(location.hash.slice(1)));"
    "if(!t)return;var d=t.querySelector(':scope>details');if(d)d.open=true;"
    "for(;t;t=t.parentElement){if(t.tagName==='DETAILS')t.open=true;}}"
    "addEventListener('hashchange',tbOpen);addEventListener('DOMContentLoaded',tbOpen);"
)


def num(x: Any, digits: int = 3) -> str:
    """A table cell's number: thousands separated, ``digits`` significant digits, ``–`` for none.

    >>> num(1234567), num(0.000123456), num(float("nan")), num(True), num(2.5e6, 2)
    ('1,234,567', '0.000123', '–', 'yes', '2.50e+06')
    """
    if x is None or (isinstance(x, float) and not math.isfinite(x)):
        return "–"
    if isinstance(x, (bool, np.bool_)):
        return "yes" if x else "no"
    if isinstance(x, (int, np.integer)):
        return f"{int(x):,}"
    if isinstance(x, (float, np.floating)):
        v = float(x)
        if v == 0:
            return "0"
        return f"{v:.{digits}g}" if abs(v) < 1e5 else f"{v:.{digits}e}"
    return str(x)


def span(low: float, high: float, unit: str = "") -> str:
    """``low–high`` at 3 significant digits, one number where they agree, ``–`` for a non-finite end."""
    if not (math.isfinite(low) and math.isfinite(high)):
        return "–"
    return f"{low:.3g}{unit}" if f"{low:.3g}" == f"{high:.3g}" else f"{low:.3g}–{high:.3g}{unit}"


def plain(v: Any) -> str:
    """A value of a record (list, dict, None) as one line of text."""
    if v is None:
        return "–"
    if isinstance(v, (list, tuple)):
        return ", ".join(plain(x) for x in v)
    if isinstance(v, dict):
        return ", ".join(f"{k} {plain(x)}" for k, x in v.items())
    return str(v)


def p(text: str, cls: str = "") -> str:
    """A paragraph of ``text``, with a CSS class (``note``, ``sub``) if given."""
    c = f' class="{escape(cls)}"' if cls else ""
    return f"<p{c}>{escape(text)}</p>"


def warn(text: str) -> str:
    """A warning box."""
    return f'<div class="warn">{escape(text)}</div>'


def code(text: str) -> str:
    """A block of commands or a file, as written."""
    return f"<pre><code>{escape(text)}</code></pre>"


def table(
    frame: pd.DataFrame,
    cols: Sequence[tuple[str, str]],
    digits: int = 4,
    classes: Mapping[str, Callable[[Any], str]] | None = None,
    titles: Mapping[str, str] | None = None,
) -> str:
    """An HTML table of ``frame``; ``cols`` pairs a column with its header (units in it).

    A ``verdict`` cell takes its verdict as CSS class; ``classes`` maps a column to a function from a
    cell's value to its CSS class; ``titles`` maps a column to its header's tooltip."""
    if frame.empty:
        return '<p class="note">(none)</p>'
    tips = titles or {}
    head = "".join(
        f'<th title="{escape(tips[c])}">{escape(h)}</th>' if c in tips else f"<th>{escape(h)}</th>" for c, h in cols
    )
    body = []
    for _, row in frame.iterrows():
        cells = []
        for c, _ in cols:
            v = row.get(c)
            numeric = isinstance(v, (int, float, np.integer, np.floating)) and not isinstance(v, (bool, np.bool_))
            cls = ' class="num"' if numeric else ""
            if c == "verdict" and isinstance(v, str):
                cls = f' class="{escape(v)}"'
            if classes and c in classes:
                cls = f' class="{escape(classes[c](v))}"'
            cells.append(f"<td{cls}>{escape(num(v, digits))}</td>")
        body.append("<tr>" + "".join(cells) + "</tr>")
    return f"<table><thead><tr>{head}</tr></thead><tbody>{''.join(body)}</tbody></table>"


def kv_table(items: Iterable[tuple[Any, Any]]) -> str:
    """A two-column table: one row per (name, value)."""
    rows = "".join(f"<tr><th>{escape(str(k))}</th><td>{escape(plain(v))}</td></tr>" for k, v in items)
    return f"<table>{rows}</table>"


def figure(uri: str, alt: str, caption: str, img_class: str = "") -> str:
    """An image (a ``data:`` URI) with its caption."""
    c = f' class="{escape(img_class)}"' if img_class else ""
    return (
        f'<figure><img src="{escape(uri)}" alt="{escape(alt)}"{c}><figcaption>{escape(caption)}</figcaption></figure>'
    )


def png_data_uri(data: bytes) -> str:
    """PNG bytes as a ``data:image/png;base64,...`` URI, for :func:`figure`."""
    return "data:image/png;base64," + base64.b64encode(data).decode()


def palette_png(data: bytes) -> bytes:
    """PNG bytes re-encoded with a 256-colour palette: a plot's flat colours look the same at a third of the bytes."""
    from PIL import Image

    out = io.BytesIO()
    with Image.open(io.BytesIO(data)) as im:
        im.convert("RGB").quantize(256, method=Image.Quantize.FASTOCTREE).save(out, format="PNG", optimize=True)
    return out.getvalue()


def section(sid: str, title: str | None, body: str, collapsed: bool = False) -> str:
    """``<section id=sid>`` with ``title`` as its heading (none if None) above ``body``, hidden under
    the title until opened when ``collapsed``.

    >>> section("x", "X", "<p>b</p>", collapsed=True)
    '<section id="x"><details><summary><h2>X</h2></summary><p>b</p></details></section>'
    """
    h2 = f"<h2>{escape(title)}</h2>" if title is not None else ""
    if collapsed:
        return f'<section id="{escape(sid)}"><details><summary>{h2}</summary>{body}</details></section>'
    return f'<section id="{escape(sid)}">{h2}{body}</section>'


def now() -> str:
    """The time a page is written, for its footer (UTC, seconds)."""
    return _dt.datetime.now(_dt.UTC).isoformat(timespec="seconds")


def document(title: str, body: str, nav: Mapping[str, str] | None = None, written: str = "") -> str:
    """A whole page: ``nav`` maps section ids to the titles linked from the bar at the top; ``written``: by what,
    when and from what, for the footer (none if empty). A body that draws a chart gets the charts' library, once,
    in the head.

    >>> page = document("a <b>", section("x", "X", p("text")), nav={"x": "X"})
    >>> page.startswith("<!DOCTYPE html>") and "<title>a &lt;b&gt;</title>" in page
    True
    >>> page[page.index("<nav>"):page.index("</main>")]
    '<nav><a href="#x">X</a></nav><main><section id="x"><h2>X</h2><p>text</p></section>'
    """
    links = "".join(f'<a href="#{escape(sid)}">{escape(t)}</a>' for sid, t in (nav or {}).items())
    bar = f"<nav>{links}</nav>" if links else ""
    end = (
        f"<footer>{p(f'Written by {written}. Statistics: tribench.harness.stats.', 'note')}</footer>" if written else ""
    )
    script = library() if USED in body else ""
    if "</script" in script.lower():
        raise ValueError("a page's script must not contain '</script'")  # it would end the element early
    head = f"<script>{script}</script>" if script else ""
    opener = f"<script>{_OPEN_TARGET}</script>" if "><details><summary><h2>" in body else ""
    return (
        '<!DOCTYPE html>\n<html lang="en"><head><meta charset="utf-8">'
        '<meta name="viewport" content="width=device-width, initial-scale=1">'
        f"<title>{escape(title)}</title><style>{CSS}</style>{head}{opener}</head><body>"
        f"{bar}<main>{body}{end}</main></body></html>\n"
    )
