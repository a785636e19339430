"""Building elements from a reconstruction's spaces and the scan (docs/method.md §7).

Both methods end with interior spaces; this stage turns them into what a BIM tool expects:
wall runs with a thickness (interior between two rooms, exterior around the building), joined
at corners and T-junctions; floor and ceiling/roof slabs per storey; one exterior per storey;
doors, doorless openings and windows found in the walls from the scan.
"""
