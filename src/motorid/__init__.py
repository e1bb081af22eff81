"""motorid: identify a DC servo-motor model from oscilloscope step captures.

Data flows one way: :mod:`motorid.io` (read capture files) →
:mod:`motorid.conditioning` (edge, sync, unwrap, reduce, differentiate, denoise) →
identification → model → control/simulation → report.  :mod:`motorid.trainer` is the
virtual servo trainer that stands in for the bench hardware.
"""

from motorid.capture import Capture, ChannelInfo, ScopeInfo
from motorid.errors import MotorIdError

__all__ = ["Capture", "ChannelInfo", "ScopeInfo", "MotorIdError"]
__version__ = "0.1.0"
