// ivoct export/ — output files (io/'s temporaries, renamed when complete) and the
// metadata strings of every format.  Built into export/ and into each of its
// modules (module.h): the io/ functions it calls are the host's in all of them.
#include <cerrno>
#include <cstring>

#include "internal.hpp"

namespace ivexp {

Output::Output(const char *path) : path_(path)
{
    ivoct_error_t err;
    ivoct_error_clear(&err);
    if (io_open(&f_, path, &err))
        throw Error(err.msg);
    open_ = true;
}

Output::~Output()
{
    if (open_)
        io_abort(&f_);
}

void Output::write(const void *data, size_t n)
{
    if (n && fwrite(data, 1, n, f_.f) != n)
        throw Error("cannot write " + path_ + ": " + std::strerror(errno ? errno : EIO));
    size_ += n;
}

void Output::write_at(uint64_t offset, const void *data, size_t n)
{
    if (!seekable())
        throw Error("cannot write " + path_ + ": a device or a pipe cannot be rewritten");
    if (offset + n > size_)
        throw Error("cannot write " + path_ + ": a rewrite past the end (a bug of ivoct)");
    if (fseeko(f_.f, (off_t)offset, SEEK_SET) != 0)
        throw Error("cannot write " + path_ + ": " + std::strerror(errno ? errno : EIO));
    if (n && fwrite(data, 1, n, f_.f) != n)
        throw Error("cannot write " + path_ + ": " + std::strerror(errno ? errno : EIO));
    if (fseeko(f_.f, 0, SEEK_END) != 0)
        throw Error("cannot write " + path_ + ": " + std::strerror(errno ? errno : EIO));
}

void Output::commit()
{
    ivoct_error_t err;
    ivoct_error_clear(&err);
    open_ = false;
    if (io_commit(&f_, &err))  // removes the temporary on failure
        throw Error(err.msg);
}

std::vector<MetaItem> meta_strings(const oct_source_t *src)
{
    std::vector<MetaItem> items;
    if (src && src->name)
        items.push_back({"scene", src->name});
    for (size_t i = 0; src && i < src->n_lets; i++)
        if (src->let_names && src->let_texts && src->let_names[i] && src->let_texts[i])
            items.push_back({std::string("let.") + src->let_names[i], src->let_texts[i]});
    if (src && src->f)
        items.push_back({"expression", src->f});
    items.push_back({"creator", "ivoct"});
    return items;
}

}  // namespace ivexp
