------------------------------ MODULE MCDiscovery ------------------------------
(* Model values: two bridges, two addresses each.  Class 10 expects        *)
(* layout "A", class 20 layout "B" (one expected fingerprint per class, so *)
(* a check against the wrong class is caught).  The classes lie outside    *)
(* the addresses (1..NAddr, also in MCDiscoveryLarge), so a slot built     *)
(* from a class instead of an address does not exist and TLC refutes it.   *)
(* Identities: class 10 index 0 with its own layout, class 10 index 1 with *)
(* class 20's layout (a mismatch, and the same class as the first with     *)
(* another index: not a duplicate), and class 20 index 0 (the same index   *)
(* as the first in another class: not a duplicate either).  A duplicate is *)
(* one identity wired twice.  Every wiring of these to the four slots is   *)
(* explored (Init chooses pop).                                            *)
EXTENDS Discovery

ClassA == 10
ClassB == 20
MCIdents == { [class |-> ClassA, index |-> 0, fp |-> "A"],
              [class |-> ClassA, index |-> 1, fp |-> "B"],
              [class |-> ClassB, index |-> 0, fp |-> "B"] }
MCExpected == [c \in {ClassA, ClassB} |-> IF c = ClassA THEN "A" ELSE "B"]
=============================================================================
