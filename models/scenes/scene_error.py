"""The one error a scene raises: a bad scene name, parameter or world file (``SceneError``, a ValueError), so that
``make sim`` and every scene builder report bad input the same way: one line naming the problem."""


class SceneError(ValueError):
    """A bad scene name or parameter."""
