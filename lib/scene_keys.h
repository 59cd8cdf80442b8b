/* SPDX-License-Identifier: MIT */
/*
 * The scene keys of [initial], [integrator], [output] and [events] as one table (scene_keys.c):
 * each key's type, where its value goes, its bounds and its doc. One generic parser reads every
 * key; the messages, the "unknown key" lists and the user guide's key tables are made from it.
 */
#ifndef DTH_SCENE_KEYS_H
#define DTH_SCENE_KEYS_H

#include <stddef.h>
#include "dth/scene.h"

/* What the table's keys set besides dth_run_setup: read by the cross-key rules and the events'
 * builder of scene.c. The lists are owned (dth__scene_extra_clear). */
typedef struct dth__scene_extra {
    size_t np;              /* initial.p: how many values (checked against q's) */
    int points;             /* output.points: -1 auto, else a dth_points */
    long section;           /* events.section: +i for q<i>, -i for p<i> (1-based i); 0 none */
    double section_value;
    int section_direction;  /* +1 up, -1 down, 0 both */
    int section_terminal;
    double *times;          /* events.time */
    size_t ntimes;
    int time_terminal;
    double distance;        /* events.distance (> 0 when given) */
    size_t *dofs;           /* events.distance_dofs as given (1-based) */
    size_t ndofs;
    int distance_direction;
    int distance_terminal;
} dth__scene_extra;

/* Where a value goes: a member of the run setup or of the extra struct. */
enum { DTH__IN_NONE = 0, DTH__IN_SETUP = 1, DTH__IN_EXTRA = 2 };
typedef struct dth__scene_slot {
    unsigned char base; /* DTH__IN_* */
    unsigned char size; /* sizeof the member */
    size_t off;         /* offsetof the member */
} dth__scene_slot;

/* How a NUMBER's value is bounded. */
enum { DTH__ANY = 0, DTH__GE, DTH__GT, DTH__NONZERO };

/* One name a BOOL or CHOICE key accepts; an alias is accepted but not listed. */
typedef struct dth__choice {
    const char *name;
    int value;
    int alias;
    const char *doc;
} dth__choice;
/* Choice j into *c: 1, or 0 past the last. */
typedef int (*dth__choice_fn)(size_t j, dth__choice *c);

typedef struct dth__scene_key {
    dth_scene_key_info info;  /* first: dth_scene_key_at points here */
    dth__scene_slot to;       /* the value (a list: its pointer) */
    dth__scene_slot count;    /* NUMBERS, DOFS: how many values */
    dth__scene_slot given;    /* an int set to 1 when the key is given (initial.wp: opt.has_wp) */
    int bound;                /* NUMBER: DTH__ANY, DTH__GE or DTH__GT lo, DTH__NONZERO */
    double lo;
    long ilo, ihi;            /* INTEGER: the range */
    const char *note;         /* appended to the description: "(0: estimate K locally)" */
    const char *refuse;       /* the message for a number of the right form out of bounds (default: "'v' is not ...") */
    dth__choice_fn choice;    /* BOOL, CHOICE */
    int as_name;              /* CHOICE: 0 stores the choice's value; DTH__NAME_GIVEN its name (static), a name
                                 not in the list as given, left to dth_options_check to word (integrator.method);
                                 DTH__NAME_KNOWN its name (static), a name not in the list refused here
                                 (integrator.table) */
} dth__scene_key;

/* dth__scene_key.as_name */
enum { DTH__NAME_GIVEN = 1, DTH__NAME_KNOWN = 2 };

/* Where a parsed value goes. */
typedef struct dth__scene_target {
    dth_run_setup *rs;
    dth__scene_extra *x;
    const dth_allocator *alloc;
} dth__scene_target;

/* The sections a scene may hold: the model's parameters, the table's keys, the regularizer's. */
enum { DTH__SECTION_UNKNOWN = 0, DTH__SECTION_MODEL, DTH__SECTION_KEYS, DTH__SECTION_REGULARIZE };
int dth__scene_section_kind(const char *section);

/* The table's entry i (NULL past the end), and the entry of section.key (NULL if none). */
const dth__scene_key *dth__scene_key_get(size_t i);
const dth__scene_key *dth__scene_key_find(const char *section, const char *key);

/* The run setup's and the extra struct's values before any key is read (rs and x are overwritten). */
void dth__scene_defaults(dth_run_setup *rs, dth__scene_extra *x, const dth_allocator *alloc);
/* Release the extra struct's lists. */
void dth__scene_extra_clear(dth__scene_extra *x, const dth_allocator *alloc);

/* Read `value` for key k into t: DTH_OK; DTH_EINVAL with the message in msg (without the origin and
 * the key: "'abc' is not a finite number"); DTH_ENOMEM. */
int dth__scene_key_parse(const dth__scene_key *k, const char *value, const dth__scene_target *t, char *msg,
                         size_t len);
/* What the key accepts ("an integer in 1..100000", "one of midpoint, vertex"), as snprintf. */
size_t dth__scene_key_describe(const dth__scene_key *k, char *buf, size_t len);

/* The message for section.key not in the table: the section's keys, and the closest one. */
void dth__scene_unknown_key(const char *section, const char *key, char *msg, size_t len);
/* The message for an unknown section: the known ones, and the closest one. */
void dth__scene_unknown_section(const char *section, char *msg, size_t len);

/* "Did you mean": offer candidates one at a time; best is the closest within a small edit distance
 * (optimal string alignment: a swap of two neighbours counts as one edit), the first on a tie. */
typedef struct dth__suggest {
    const char *word, *best;
    size_t dist;
} dth__suggest;
void dth__suggest_init(dth__suggest *s, const char *word);
void dth__suggest_offer(dth__suggest *s, const char *candidate);

#endif
