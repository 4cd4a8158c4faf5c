# Sourced by the A/B scripts of docs/results (not run on its own), with $old set to the old
# build's pmg binary: pmg_of WHO, the binary of the round's build (old: $old, new: build/tools/pmg),
# and ab_order R, the builds' order in round R ("old new" in odd rounds, "new old" in even ones).
pmg_of() { if [ "$1" = old ]; then echo "$old"; else echo build/tools/pmg; fi; }
ab_order() { if [ $(($1 % 2)) -eq 0 ]; then echo "new old"; else echo "old new"; fi; }
