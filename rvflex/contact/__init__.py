"""Force elements of the reducer model: cycloid–pin contact, clearance bearings, involute mesh."""
