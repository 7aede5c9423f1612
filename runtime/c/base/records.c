/* records.c: the data entries of an event record, (key, member) -> a number, a text, a truth
 * value or None, kept in the order first set (a Python dict's) (base.h).
 */
#include <string.h>

#include "base.h"

/* The entry (key, member) of data (n entries, room for capacity): the existing one, or a
   new one at the end (a dict's assignment); NULL when full. */
dep_datum *dep_datum_add(dep_datum *data, int *n, int capacity, const char *key,
                         const char *member)
{
    for (int i = 0; i < *n; ++i) {
        if (strcmp(data[i].key, key) == 0 && strcmp(data[i].member, member) == 0) {
            return &data[i];
        }
    }
    if (*n == capacity) {
        return NULL;
    }
    dep_datum *d = &data[(*n)++];
    memset(d, 0, sizeof *d);
    dep_copy_text(d->key, sizeof d->key, key);
    dep_copy_text(d->member, sizeof d->member, member);
    return d;
}

void dep_datum_number(dep_datum *data, int *n, int capacity, const char *key, double value)
{
    dep_datum *d = dep_datum_add(data, n, capacity, key, "");
    if (d != NULL) {
        d->kind = DEP_NUMBER;
        d->number = value;
    }
}

void dep_datum_text(dep_datum *data, int *n, int capacity, const char *key, const char *text)
{
    dep_datum *d = dep_datum_add(data, n, capacity, key, "");
    if (d != NULL) {
        d->kind = DEP_TEXT;
        dep_copy_text(d->text, sizeof d->text, text);
    }
}
