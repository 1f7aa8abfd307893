"""Writers and readers: particle snapshots, checkpoints. Writers never change the state."""
