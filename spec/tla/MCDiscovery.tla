------------------------------ MODULE MCDiscovery ------------------------------
(* Model values: two bridges, two addresses each.  Class 1 expects layout  *)
(* "A", class 2 layout "B" (one expected fingerprint per class, so a check *)
(* against the wrong class is caught).  Identities: class 1 index 0 with   *)
(* its own layout, class 1 index 1 with class 2's layout (a mismatch, and *)
(* the same class as the first with another index: not a duplicate), and  *)
(* class 2 index 0 (the same index as the first in another class: not a   *)
(* duplicate either).  A duplicate is one identity wired twice.  Every     *)
(* wiring of these to the four slots is explored (Init chooses pop).       *)
EXTENDS Discovery

MCIdents == { [class |-> 1, index |-> 0, fp |-> "A"],
              [class |-> 1, index |-> 1, fp |-> "B"],
              [class |-> 2, index |-> 0, fp |-> "B"] }
MCExpected == [c \in {1, 2} |-> IF c = 1 THEN "A" ELSE "B"]
=============================================================================
