"""The contact model: stateless slot kernels (``laws``), their composition for one scene
(``model``), and the contact history keyed by particle-id pairs (``history``)."""
