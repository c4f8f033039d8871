#!/usr/bin/env python3
"""Issue 7 yardstick: what the numpy peer spends merely decoding images, as peer.py's load does
(PIL open + convert("L") + numpy asarray, / 255), one file after another, nothing estimated.

  peer_decode.py FOLDER      (every .png in FOLDER, sorted)
"""
import os, sys
import numpy as np
from PIL import Image

d = sys.argv[1]
files = sorted(f for f in os.listdir(d) if f.endswith(".png"))
X = np.stack([np.asarray(Image.open(os.path.join(d, f)).convert("L"), dtype=np.float64).ravel() / 255.0 for f in files])
print(X.shape, file=sys.stderr)
