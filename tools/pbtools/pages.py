"""HTML pages from the Jinja2 templates in templates/, always autoescaped: every value a template
prints (scene, technique and cell names, reasons, warnings, run.json fields) is text, so a name
holding `<script>` or `&` shows as written and cannot change the page. Markup belongs in the
templates only; the Python side hands them plain values (numbers already formatted) and lists."""

from __future__ import annotations

import os
from functools import lru_cache

import jinja2

TEMPLATES_DIR = os.path.join(os.path.dirname(os.path.abspath(__file__)), "templates")


@lru_cache(maxsize=None)
def environment() -> jinja2.Environment:
    return jinja2.Environment(
        loader=jinja2.FileSystemLoader(TEMPLATES_DIR),
        autoescape=True,
        undefined=jinja2.StrictUndefined,  # a value the page uses that the code did not pass: error
        trim_blocks=True,
        lstrip_blocks=True,
        keep_trailing_newline=True,
    )


def render(template: str, **context) -> str:
    return environment().get_template(template).render(**context)
