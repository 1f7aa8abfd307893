"""What holds the free disks in: the boundary protocol (``protocol.py``: a descriptor per kind
of boundary), its registry (``registry.py``), the two rings of the Couette cell (``walls.py``:
their motion, glued wall disks and flat surfaces; ``ring_forces.py``: the flat-surface
contacts) and fixed wall disks from a user's file (``wall_file.py``)."""
