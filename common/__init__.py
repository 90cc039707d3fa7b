"""What every tribench package shares, at the bottom of the import order.

``tribench.common`` may import nothing else of tribench, and every other package
may import it: the one user-error type (:mod:`.errors`) and the one atomic
file write (:mod:`.files`).
"""

from .errors import Notice, UserError, UserTypeError
from .files import atomic_write, read_user_text, write_bytes, write_text

__all__ = ["Notice", "UserError", "UserTypeError", "atomic_write", "read_user_text", "write_bytes", "write_text"]
