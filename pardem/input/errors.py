"""The error a user's input raises: ``SceneError`` (a scene file, a command-line value, a
checkpoint or a run folder), whose message names the key, the value and what is allowed.

Stage: input. Kept apart so that the checks of every stage (values.py, the contact laws'
descriptors) can raise it without importing the scene types.
"""


class SceneError(ValueError):
    """An invalid scene; the message names the table and key at fault."""
