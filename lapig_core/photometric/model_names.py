"""The names of the two compensators and the classical model's file: plain constants, no torch, so the first look
(numpy) and Train's choice (torch) share them."""

LEARNED, CLASSICAL = "CompenNeSt", "classical"
CLASSICAL_FILE = "classical.npz"
