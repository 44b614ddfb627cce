"""handvar: model-based 3D hand tracking with online, adaptive VAR motion prediction.

Implements Chik, Trumpf & Schraudolph, "Using an Adaptive VAR Model for Motion
Prediction in 3D Hand Tracking", and goes beyond it.
"""

__version__ = "0.1.0"
