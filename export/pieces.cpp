// ivoct export/ — the indexes of partitioned outputs (the build over MPI): a
// .pvtu over .vtu pieces, and the cell list's .pcsv over CSV pieces.  No VTK
// here: a .pvtu is a short XML file naming the pieces and declaring their
// arrays, and those declarations are copied from a piece's own header, so the
// index cannot drift from what exp_vtu writes.
#include <cstring>
#include <string>

#include "internal.hpp"

namespace {

// The value of attribute `name` in the XML start tag `tag` ("" when absent).
std::string attribute(const std::string &tag, const char *name)
{
    std::string key = std::string(" ") + name + "=\"";
    size_t at = tag.find(key);
    if (at == std::string::npos)
        return "";
    at += key.size();
    size_t end = tag.find('"', at);
    return end == std::string::npos ? "" : tag.substr(at, end - at);
}

// The header of a VTK XML file: everything before its appended data.
std::string xml_header(const char *path)
{
    FILE *f = std::fopen(path, "rb");
    if (!f)
        throw ivexp::Error(std::string("cannot read ") + path + ": " + std::strerror(errno));
    std::string head;
    char buf[65536];
    size_t n;
    while ((n = std::fread(buf, 1, sizeof buf, f)) > 0) {
        head.append(buf, n);
        size_t cut = head.find("<AppendedData");
        if (cut != std::string::npos) {
            head.resize(cut);
            break;
        }
    }
    std::fclose(f);
    return head;
}

// The <PDataArray> lines of the DataArrays inside section `section` of head.
std::string parallel_arrays(const std::string &head, const char *section)
{
    std::string open = std::string("<") + section, close = std::string("</") + section + ">";
    size_t from = head.find(open);
    if (from == std::string::npos)
        return "";
    size_t to = head.find(close, from);
    if (to == std::string::npos)
        throw ivexp::Error("a piece's " + std::string(section) + " is not closed");
    std::string out;
    for (size_t at = head.find("<DataArray", from); at != std::string::npos && at < to;
         at = head.find("<DataArray", at + 1)) {
        std::string tag = head.substr(at, head.find('>', at) - at);
        out += "      <PDataArray type=\"" + attribute(tag, "type") + "\"";
        std::string name = attribute(tag, "Name"), comps = attribute(tag, "NumberOfComponents");
        if (!name.empty())
            out += " Name=\"" + name + "\"";
        if (!comps.empty())
            out += " NumberOfComponents=\"" + comps + "\"";
        out += "/>\n";
    }
    return out;
}

void write_all(const char *path, const std::string &text)
{
    ivoct_error_t e;
    ivoct_error_clear(&e);
    io_file_t f;
    if (io_open(&f, path, &e))
        throw ivexp::Error(e.msg);
    if (std::fwrite(text.data(), 1, text.size(), f.f) != text.size()) {
        io_abort(&f);
        throw ivexp::Error(std::string("cannot write ") + path + ": " + std::strerror(errno));
    }
    if (io_commit(&f, &e))
        throw ivexp::Error(e.msg);
}

} // namespace

int exp_pvtu_index(const char *path, const char *piece, const char *const *sources, int n,
                   ivoct_error_t *err)
{
    return ivexp::guard(err, [&] {
        std::string head = xml_header(piece);
        std::string vtkfile = head.substr(0, head.find('>', head.find("<VTKFile")));
        if (vtkfile.find("UnstructuredGrid") == std::string::npos)
            throw ivexp::Error(std::string(piece) + " is not a .vtu piece");
        std::string x = "<?xml version=\"1.0\"?>\n<VTKFile type=\"PUnstructuredGrid\" version=\"" +
                        attribute(vtkfile, "version") + "\" byte_order=\"" +
                        attribute(vtkfile, "byte_order") + "\" header_type=\"" +
                        attribute(vtkfile, "header_type") + "\">\n"
                        "  <PUnstructuredGrid GhostLevel=\"0\">\n";
        x += "    <PPointData>\n" + parallel_arrays(head, "PointData") + "    </PPointData>\n";
        x += "    <PCellData>\n" + parallel_arrays(head, "CellData") + "    </PCellData>\n";
        x += "    <PPoints>\n" + parallel_arrays(head, "Points") + "    </PPoints>\n";
        for (int i = 0; i < n; i++)
            x += "    <Piece Source=\"" + std::string(sources[i]) + "\"/>\n";
        x += "  </PUnstructuredGrid>\n</VTKFile>\n";
        write_all(path, x);
    });
}

int exp_cells_index(const char *path, const char *const *sources, const uint64_t *leaves, int n,
                    ivoct_error_t *err)
{
    return ivexp::guard(err, [&] {
        uint64_t total = 0;
        for (int i = 0; i < n; i++)
            total += leaves[i];
        std::string x = "# ivoct cell list in " + std::to_string(n) + " pieces, " +
                        std::to_string(total) + " leaves; one piece per line: file,leaves\n";
        for (int i = 0; i < n; i++)
            x += std::string(sources[i]) + "," + std::to_string(leaves[i]) + "\n";
        write_all(path, x);
    });
}
