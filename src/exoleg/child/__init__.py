"""The child as an actor: passive joint moments, spasticity and the child's own effort."""
