"""A scene from its TOML file to frozen dataclasses (``scene.py``, ``scene_file.py``), its
checks (``schema.py``, ``values.py``), the particles it asks for (``particles.py``) and their
initial placement (``placement.py``); ``errors.SceneError`` names a bad key and its value."""
