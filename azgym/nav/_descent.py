"""Compiled walks: down the planner's cost-to-go field, and along a planned path.

A field holds, for every cell, the cost of the cheapest path from it to the goal over the grid's
16-neighbourhood (:data:`MOVES`); occupied cells hold inf. From any cell the cheapest path is the
steepest descent of the field: each step goes to the neighbour of least cost, until the goal
(cost 0). A planned path is then followed by projecting each pose onto it. Both run every
control step, so they are compiled.
"""

from __future__ import annotations

import math

import numpy as np

from azgym.jit import jit

MOVES = np.array([[0, 1], [1, 0], [0, -1], [-1, 0], [1, 1], [1, -1], [-1, -1], [-1, 1],
                  [1, 2], [2, 1], [2, -1], [1, -2], [-1, -2], [-2, -1], [-2, 1], [-1, 2]],
                 dtype=np.int64)
"""(row, column) steps of the 16-neighbourhood: 4 straight, 4 diagonal, 8 knight's moves. Knight's
moves let a path head off at 26.6° and 63.4° as well as at multiples of 45°, so a path's length
is within 2.7 % of the straight line's (8 neighbours: 8.2 %)."""


@jit
def move_allowed(free, row, column, move_row, move_column):
    """Whether the step from (row, column) by (move_row, move_column) stays on free cells.

    Both ends must be free, and a knight's move also needs the two cells it cuts across.
    """
    ny, nx = free.shape
    to_row, to_column = row + move_row, column + move_column
    if not (0 <= to_row < ny and 0 <= to_column < nx and free[to_row, to_column]):
        return False
    if abs(move_row) + abs(move_column) == 3:
        half_row = move_row // 2 if abs(move_row) == 2 else 0
        half_column = move_column // 2 if abs(move_column) == 2 else 0
        if not (free[row + half_row, column + half_column]
                and free[row + move_row - half_row, column + move_column - half_column]):
            return False
    return True


@jit
def descend(field, weight, free, moves, row, column, resolution, max_length, rows, columns):
    """Follow the cheapest path down the field from (row, column), at most ``max_length`` [m].

    Each step takes the move that minimizes the neighbour's cost to go plus the move's own
    cost (its length times the mean clearance ``weight`` of its two cells): the search's
    shortest-path tree. (The neighbour of least cost alone would favour long knight's moves and
    zigzag down a straight aisle.) Writes the visited cells, the start first, into ``rows`` and
    ``columns`` and returns how many there are and the path's length [m]. Stops at the goal
    (cost 0), after ``max_length``, when no move lowers the cost (never, on a field from the
    search) or when the buffers fill.
    """
    count = 0
    length = 0.0
    rows[0] = row
    columns[0] = column
    count = 1
    while length < max_length and count < rows.shape[0] and field[row, column] > 0.0:
        best = field[row, column]
        best_move = -1
        for m in range(moves.shape[0]):
            to_row = row + moves[m, 0]
            to_column = column + moves[m, 1]
            if not move_allowed(free, row, column, moves[m, 0], moves[m, 1]):
                continue
            step = resolution * math.hypot(moves[m, 0], moves[m, 1]) * 0.5 * (
                weight[row, column] + weight[to_row, to_column])
            if field[to_row, to_column] < field[row, column] and (
                    field[to_row, to_column] + step < best or best_move < 0):
                best = field[to_row, to_column] + step
                best_move = m
        if best_move < 0:
            break
        length += resolution * math.hypot(moves[best_move, 0], moves[best_move, 1])
        row += moves[best_move, 0]
        column += moves[best_move, 1]
        rows[count] = row
        columns[count] = column
        count += 1
    return count, length


@jit
def follow(points, arcs_along, x, y, index, back, ahead):
    """Project (x, y) onto a path near where it was: the nearest point of its segments.

    Only the segments whose start lies within ``back`` metres behind and ``ahead`` metres
    ahead of point ``index`` are searched, so a path that passes the same place twice is
    followed in order. Returns the segment's index, the arc length of the projection [m] and
    its distance from (x, y) [m].
    """
    count = points.shape[0]
    first = index
    while first > 0 and arcs_along[index] - arcs_along[first - 1] <= back:
        first -= 1
    best_distance = math.inf
    best_segment = index
    best_arc = arcs_along[index]
    k = first
    while k < count - 1 and arcs_along[k] - arcs_along[index] <= ahead:
        ax, ay = points[k, 0], points[k, 1]
        dx, dy = points[k + 1, 0] - ax, points[k + 1, 1] - ay
        length2 = dx * dx + dy * dy
        t = 0.0
        if length2 > 0.0:
            t = min(1.0, max(0.0, ((x - ax) * dx + (y - ay) * dy) / length2))
        distance = math.hypot(x - ax - t * dx, y - ay - t * dy)
        if distance < best_distance:
            best_distance = distance
            best_segment = k
            best_arc = arcs_along[k] + t * (arcs_along[k + 1] - arcs_along[k])
        k += 1
    return best_segment, best_arc, best_distance


@jit
def points_at(points, arcs_along, segment, arcs, out):
    """The points at arc lengths ``arcs`` [m] (ascending) along a path, into ``out`` (x, y).

    The search starts at ``segment``; arcs beyond the path's end give its last point.
    """
    count = points.shape[0]
    k = segment
    for a in range(arcs.shape[0]):
        while k < count - 1 and arcs_along[k + 1] < arcs[a]:
            k += 1
        if k >= count - 1:
            out[a, 0] = points[count - 1, 0]
            out[a, 1] = points[count - 1, 1]
            continue
        span = arcs_along[k + 1] - arcs_along[k]
        t = min(1.0, max(0.0, (arcs[a] - arcs_along[k]) / span)) if span > 0.0 else 1.0
        out[a, 0] = points[k, 0] + t * (points[k + 1, 0] - points[k, 0])
        out[a, 1] = points[k, 1] + t * (points[k + 1, 1] - points[k, 1])
