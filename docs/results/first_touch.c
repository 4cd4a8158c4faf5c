// First touch against second touch of fresh memory, 4 KiB or 2 MiB (transparent huge) pages:
//   gcc -O2 -o /tmp/first_touch docs/results/first_touch.c && /tmp/first_touch MB HUGE
// HUGE 1 asks for huge pages (madvise MADV_HUGEPAGE), 0 forbids them. Prints ms for each pass.
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>
#include <sys/mman.h>
static double now(){struct timespec t; clock_gettime(CLOCK_MONOTONIC,&t); return t.tv_sec+1e-9*t.tv_nsec;}
int main(int argc,char**argv){ size_t n=(size_t)atoi(argv[1])<<20; int huge=atoi(argv[2]);
 char*p=aligned_alloc(1<<21,n); if(huge) madvise(p,n,MADV_HUGEPAGE); else madvise(p,n,MADV_NOHUGEPAGE);
 double t0=now(); memset(p,1,n); double t1=now(); memset(p,2,n); double t2=now();
 printf("%zu MB huge=%d first touch %.2f ms (%.2f ms/MB), second %.2f ms\n", n>>20, huge, 1e3*(t1-t0), 1e3*(t1-t0)/(n>>20), 1e3*(t2-t1)); volatile char sink = p[100]; (void)sink; free(p); return 0;}
