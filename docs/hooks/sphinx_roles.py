"""A griffe extension for the API reference: the docstrings' Sphinx roles (``:class:`~tissuesim.x.Y```,
``:meth:`Solver.add_load```, ``:mod:`.fixing```) become links to the objects they name.

A role's target is resolved as Sphinx would, in the scope of the documented object (its members, its module's
names and imports, relative to its package for a leading dot). The link is an *optional* cross-reference: a target
the site does not render (a private helper, a module left out of the reference) stays code text without a warning,
so the strict build still fails on every reference a page writes by hand.
"""

from __future__ import annotations

import re

import griffe

# :role:`target`, :role:`~target`, :role:`.relative`, :role:`f()`, and :role:`title <target>`
ROLE = re.compile(r":(?:class|meth|func|data|mod|attr|exc|obj):`(?:([^`<]+?)\s*<)?(~?)(\.*)([\w.]+?)(\(\))?>?`")


class SphinxRoles(griffe.Extension):
    """Rewrites each object's docstring once the object tree is complete."""

    def on_object(self, *, obj: griffe.Object, **kwargs) -> None:
        if obj.docstring is None or ":`" not in obj.docstring.value:
            return
        obj.docstring.value = ROLE.sub(lambda match: _link(obj, match), obj.docstring.value)


def _link(obj: griffe.Object, match: re.Match) -> str:
    title, short, dots, name, call = match.groups()
    text = title or (name.rsplit(".", 1)[-1] if short else name) + (call or "")
    target = _resolve(obj, dots, name)
    if target is None:
        return f"`{text}`"
    return f'<autoref identifier="{target}" optional><code>{text}</code></autoref>'


def _resolve(obj: griffe.Object, dots: str, name: str) -> str | None:
    if dots:
        module = obj.module
        package = module if module.is_package else module.parent
        for _ in range(len(dots) - 1):
            package = package.parent if package.parent is not None else package
        return f"{package.path}.{name}"
    if name.split(".")[0] == obj.package.name:
        return name
    head, _, rest = name.partition(".")
    scope = obj
    while scope is not None:
        try:
            found = scope.resolve(head)
        except (griffe.NameResolutionError, AttributeError, KeyError):
            found = None
        if found:
            return f"{found}.{rest}" if rest else found
        scope = scope.parent
    return None
