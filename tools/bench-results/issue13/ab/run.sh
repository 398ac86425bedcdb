#!/bin/bash
# Alternates the old (ac63066) and new builds: 5 rounds of spm bench --quick --repeat 1.
cd /work/main
for r in 1 2 3 4 5; do
  /tmp/old/build/spm bench --quick --repeat 1 --scenes /tmp/old/scenes --json /tmp/ab/old_$r.json > /tmp/ab/old_$r.txt 2>&1
  build/spm bench --quick --repeat 1 --scenes scenes --json /tmp/ab/new_$r.json > /tmp/ab/new_$r.txt 2>&1
done
echo done > /tmp/ab/finished
