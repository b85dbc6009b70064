"""The NumPy reference steppers of the three methods (localized-dynamic, coupled-dynamic,
coupled-classic), with what they share: Newmark's relations, the initial state, the substructure
compliances, unilateral contact and the support reactions (docs/method.md)."""
