"""The fisheye image path: lights rendered, blobs detected, ids identified or decoded."""
