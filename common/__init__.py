"""What every tribench package shares, at the bottom of the import order (it may import nothing else of
tribench): the user-error types and seconds read from the environment (:mod:`.errors`), the atomic file write
(:mod:`.files`), and an RNG seed's old name read as its new one (:mod:`.renamed`)."""

from .errors import Notice, UserError, UserTypeError, seconds_from_env
from .files import atomic_write, read_user_text, write_bytes, write_text

__all__ = [
    "Notice",
    "UserError",
    "UserTypeError",
    "atomic_write",
    "read_user_text",
    "seconds_from_env",
    "write_bytes",
    "write_text",
]
