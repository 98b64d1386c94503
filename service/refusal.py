"""The typed refusal of a request's inputs.

The processes and the mesh-control checks raise :class:`InputRefused` (what is wrong and where,
as a JSON pointer); they know nothing of HTTP. :func:`service.problems.problem_for` is the one
place that makes it a 422 problem document, and the CLI prints it as one line.
"""

from __future__ import annotations

__all__ = ["InputRefused"]


class InputRefused(Exception):
    """Inputs a process refuses: ``detail`` says what, ``pointer`` where; ``kind`` names the
    class (``invalid-input``, ``invalid-boundary``, ``invalid-mesh``, ``limit-exceeded``).

    >>> str(InputRefused("size is required", pointer="/inputs/size"))
    'size is required'
    """

    def __init__(
        self,
        detail: str,
        *,
        kind: str = "invalid-input",
        pointer: str | None = None,
        title: str | None = None,
    ) -> None:
        super().__init__(detail)
        self.detail = detail
        self.kind = kind
        self.pointer = pointer
        self.title = title
