"""Disjoint sets: the groups of items joined by pairwise links (union-find with path halving)."""
from __future__ import annotations

__all__ = ["DisjointSets"]


class DisjointSets:
    """``n`` items, each its own group until :meth:`union` joins two groups."""

    def __init__(self, n: int):
        self.parent = list(range(int(n)))

    def find(self, i: int) -> int:
        """The representative of ``i``'s group."""
        parent = self.parent
        while parent[i] != i:
            parent[i] = parent[parent[i]]
            i = parent[i]
        return i

    def union(self, i: int, j: int) -> None:
        """Join the groups of ``i`` and ``j``."""
        self.parent[self.find(i)] = self.find(j)

    def groups(self) -> list[list[int]]:
        """Every group as its items in increasing order, groups by their first item."""
        out: dict[int, list[int]] = {}
        for i in range(len(self.parent)):
            out.setdefault(self.find(i), []).append(i)
        return sorted(out.values())
