------------------------------ MODULE MCDiscovery ------------------------------
(* Model values: two bridges, two addresses each.  Identities: class 1     *)
(* index 0 with the expected fingerprint "A" and with a foreign one "B"    *)
(* (a duplicate and a mismatch at once), and class 2 index 0.  Every       *)
(* wiring of these to the four slots is explored (Init chooses pop).       *)
EXTENDS Discovery

MCIdents == { [class |-> 1, index |-> 0, fp |-> "A"],
              [class |-> 1, index |-> 0, fp |-> "B"],
              [class |-> 2, index |-> 0, fp |-> "A"] }
MCExpected == [c \in {1, 2} |-> "A"]
=============================================================================
